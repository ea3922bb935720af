"""The [il] extra: a one-line error when it is missing; configurations without the baseline keep their
digests."""

from __future__ import annotations

import sys

import pytest

from taskcond.il import ILUnavailableError, require_il
from taskcond.results import RunConfig


def test_a_missing_extra_is_one_line_naming_the_install(monkeypatch):
    monkeypatch.setitem(sys.modules, "jax", None)
    with pytest.raises(ILUnavailableError) as err:
        require_il()
    assert (
        str(err.value) == "--method image-il needs the [il] extra (jax missing): pip install 'taskcond[il]'"
    )


def test_the_checkpoint_joins_the_configuration_only_when_used():
    base = RunConfig(kind="execution", llm=None, llm_model_hash=None, prompt_version=None)
    assert "il" not in base.to_dict()
    assert base.digest == "2f30c88501a30f60"  # as before the field existed
    with_il = RunConfig(kind="execution", llm=None, llm_model_hash=None, prompt_version=None, il="p@1")
    assert with_il.digest != base.digest and with_il.differences(base.to_dict()) == [
        "il: None (file) vs 'p@1' (now)"
    ]


def test_without_the_extra_reproduce_shows_the_baseline_as_not_run_and_why(monkeypatch):
    from taskcond.cli.reproduce import _without_il
    from taskcond.reproduce import build_cells, table_specs

    spec = table_specs()["table3"]
    assert build_cells(spec, [], 1)[("primitives", "grasp", "image-il")].status == "measured"
    monkeypatch.setitem(sys.modules, "optax", None)
    cell = build_cells(_without_il(spec), [], 1)[("primitives", "grasp", "image-il")]
    assert cell.status == "not run" and "pip install 'taskcond[il]'" in cell.note
