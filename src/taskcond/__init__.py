"""taskcond: long-horizon manipulation guided by LLM-generated task conditions.

Implements Zhou et al., "Generalizable Long-Horizon Manipulations with Large Language Models"
(arXiv 2310.02264).
"""

from taskcond.conditions import (
    Collision,
    ConditionError,
    ContainerState,
    GripperState,
    Predicate,
    Relation,
    SpatialRelation,
    TaskCondition,
    parse_predicate,
)
from taskcond.primitives import (
    PRIMITIVES,
    ParsedTask,
    Primitive,
    TaskNameError,
    parse_task,
    task_for_condition,
)

__version__ = "0.1.0"

__all__ = [
    "PRIMITIVES",
    "Collision",
    "ConditionError",
    "ContainerState",
    "GripperState",
    "ParsedTask",
    "Predicate",
    "Primitive",
    "Relation",
    "SpatialRelation",
    "TaskCondition",
    "TaskNameError",
    "__version__",
    "parse_predicate",
    "parse_task",
    "task_for_condition",
]
