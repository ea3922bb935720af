"""``python -m taskcond.cli``."""

from taskcond.cli import main

main()
