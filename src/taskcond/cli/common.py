"""What the commands share: options, the one-line error, the LLM generator, the skill library."""

from __future__ import annotations

from collections.abc import Iterable
from dataclasses import dataclass, replace
from pathlib import Path
from typing import Annotated, NoReturn

import typer

from taskcond.generator import PROMPT_VERSION
from taskcond.primitives import PRIMITIVES, TaskNameError

LlmOption = Annotated[
    str | None,
    typer.Option(
        "--llm",
        help="Backend: embedded (qwen2.5-coder-0.5b for generation, qwen2.5-coder-1.5b otherwise), "
        "embedded:MODEL (that model for everything), openai, openai:MODEL. Default: $TASKCOND_LLM, the "
        "config file, else embedded.",
    ),
]
SamplesOption = Annotated[
    int,
    typer.Option(
        "--samples",
        min=1,
        help="Self-consistency, majority per condition: in the code form (every condition in v8, a left-out "
        "primitive in v6 and v7), greedy answers over this many example orders; otherwise answers sampled "
        "per chat.",
    ),
]
NoCacheOption = Annotated[
    bool, typer.Option("--no-cache", help="Do not read or write the on-disk response cache.")
]
JsonOption = Annotated[bool, typer.Option("--json", help="Print JSON instead of text.")]
WorkersOption = Annotated[
    int | None, typer.Option("--workers", min=1, help="Worker processes (default: one per core).")
]
PromptVersionOption = Annotated[
    str,
    typer.Option(
        "--prompt-version",
        help="Prompt set: v8 (default: every condition in v7's code chat, a seen primitive with its own "
        "example repeated last), v7 (v6 whose code chat says a container's state is asserted only "
        "when the task opens, closes or puts something inside it), v6 (a left-out primitive's condition "
        "written as a Python function in one chat; generation as v5), v5 (generation with the examples as "
        "earlier turns of the chat; the "
        "paper's two chain-of-thought chats for a left-out primitive, as v4), v4 (v1 whose "
        "chain-of-thought prompt shows each example with a one-line worked reasoning), v1 (the paper's "
        "Listings 2-4), v2 (v1 with the definitions of pre/post-conditions and an analogy step in the "
        "chain-of-thought prompt), v3 (no chain-of-thought text).",
    ),
]


MethodOption = Annotated[
    str,
    typer.Option(
        "--method",
        help="Execution method: llm (conditions from the LLM), llm+demo (the LLM's conditions grounded in "
        "the demonstrations), env (conditions from the demonstrations' environment information), none "
        "(DMP only).",
    ),
]
NoiseOption = Annotated[
    float,
    typer.Option("--noise", min=0.0, help="Perception noise sigma in metres on object centres and boxes."),
]
PlannerOption = Annotated[
    str,
    typer.Option(
        "--planner",
        help="conditions: check the plan against the start state with the task conditions and "
        "repair it before moving (insert, drop, reorder); none: run the plan as given, the paper's "
        "behaviour (Alg. 1 alone).",
    ),
]
StartOption = Annotated[
    str,
    typer.Option(
        "--start",
        help="Start state: task (the task's own: a suite task's initial state; for a free instruction the "
        "scene's reset, objects near their usual spots, containers closed) or random (each container open "
        "or closed with probability 1/2, free objects upright with a uniform yaw at uniform collision-free "
        "spots of the reachable table area; a suite task keeps the containers its start needs and then "
        "sets itself up, e.g. grasps the object it starts holding where it now stands; the same seed "
        "gives the same scene).",
    ),
]
SkillsOption = Annotated[
    Path | None,
    typer.Option("--skills", help="Skill library directory (default: the user cache; learned on first use)."),
]


WorldOption = Annotated[
    str,
    typer.Option(
        "--world",
        help="kitchen (the PyBullet suite, default) or robosuite (robosuite's MuJoCo tasks, ids = its "
        "environment names: Lift, Stack, PickPlaceCan, ..., PickPlace, Door, NutAssemblySquare; judged by "
        "robosuite's _check_success; needs the robosuite extra).",
    ),
]


PrimitivesOption = Annotated[
    list[Path] | None,
    typer.Option(
        "--primitives",
        envvar="TASKCOND_PRIMITIVES",
        help="Declare your own primitives from this TOML or JSON file (repeatable; also "
        "$TASKCOND_PRIMITIVES, files separated by ':'): task-name pattern, aliases, target and movable "
        "objects. See the README.",
    ),
]


ObjectsOption = Annotated[
    list[Path] | None,
    typer.Option(
        "--objects",
        envvar="TASKCOND_OBJECTS",
        help="Declare your own objects from this TOML or JSON file (repeatable; also $TASKCOND_OBJECTS, "
        "files separated by ':'): name, aliases, a shape with size or a .urdf/.obj file (pybullet_data: "
        "for PyBullet's models), mass, colour, roles graspable/container/surface/vessel. See "
        "examples/objects.toml.",
    ),
]


def _declare_objects(files: list[Path] | None) -> None:
    """Register the objects declared in ``files`` (``--objects``): one ``error:`` line naming the file and
    the entry, exit 2, for a bad declaration."""
    if not files:
        return  # the simulator (and its import banner) only when objects are declared
    from taskcond.sim.objects import ObjectError, load_objects

    for path in files:
        try:
            load_objects(path)
        except ObjectError as exc:
            fail(str(exc))


def _declare(files: list[Path] | None) -> None:
    """Register the primitives declared in ``files`` (``--primitives``)."""
    from taskcond.primitives import load_primitives

    for path in files or ():
        try:
            load_primitives(path)
        except TaskNameError as exc:
            fail(str(exc))


def fail(message: str) -> NoReturn:
    typer.echo(f"error: {message}", err=True)
    raise typer.Exit(2)


def _generator(
    llm: str | None,
    samples: int,
    no_cache: bool,
    grammar: str = "fallback",
    prompt_version: str = PROMPT_VERSION,
):

    from taskcond.generator import ConditionGenerator, prompt_versions
    from taskcond.llm.config import LLMConfig

    if prompt_version not in prompt_versions():
        fail(f"--prompt-version {prompt_version!r}: use one of {', '.join(prompt_versions())}")
    config = LLMConfig.load(llm)
    if no_cache:
        config = replace(config, cache=False)
    return ConditionGenerator.from_config(
        config, samples=samples, grammar=grammar, prompt_version=prompt_version
    )


def _sim_import() -> None:
    try:
        import pybullet  # noqa: F401
    except ImportError as exc:
        fail(f"execution needs the [sim] extra ({exc.name} missing): pip install 'taskcond[sim]'")


def _library(skills: Path | None):
    from taskcond.application.library import default_library_dir, load_library
    from taskcond.execution.skills import SkillError
    from taskcond.llm.base import cpu_count

    def told(task_id: str, ok: bool) -> None:
        typer.echo(f"  demonstrated {task_id}{'' if ok else ' (oracle failed; kept anyway)'}", err=True)

    directory = skills or default_library_dir()
    if not (directory / "library.json").exists():
        typer.echo(f"learning the skill library into {directory} (once, about a minute)", err=True)
    try:
        return load_library(directory, progress=told, workers=cpu_count())
    except SkillError as exc:
        fail(str(exc))


def _default_library_dir() -> Path:
    from taskcond.application.library import default_library_dir

    return default_library_dir()


BackendOption = Annotated[
    str,
    typer.Option(
        "--backend",
        help="Where episodes run: local (worker processes here) or ray (Ray tasks; needs the ray extra).",
    ),
]
RayAddressOption = Annotated[
    str | None,
    typer.Option(
        "--ray-address",
        help="Ray cluster to use with --backend ray (default: $RAY_ADDRESS, the Ray running on this "
        "machine, else a new local one).",
    ),
]


@dataclass(frozen=True)
class ExecutionSettings:
    """The options every episode-running command shares (eval primitives|long-horizon, reproduce)."""

    workers: int | None = None
    noise: float = 0.005
    llm: str | None = None
    skills: Path | None = None
    backend: str = "local"
    ray_address: str | None = None
    planner: str = "conditions"
    start: str = "task"
    novel_primitive: bool = False
    rerun: Path | None = None
    rerun_all: bool = False


def _crashed(crashed: list[dict]) -> None:
    """Report crashed trials (exceptions, not task failures) on stderr."""
    if crashed:
        first = crashed[0]
        typer.echo(
            f"error: {len(crashed)} trial(s) crashed and were not counted (first: {first['task']} "
            f"{first['method']} seed {first['seed']}: {first['error']}); run the same command again to "
            f"retry them",
            err=True,
        )


def _check_start(start: str) -> None:
    from taskcond.tasks.free import STARTS

    if start not in STARTS:
        fail(f"--start {start!r}: use one of {', '.join(STARTS)}")


def _require_demonstrations(library, pids: Iterable[str], leave_out: str) -> None:
    """Fail, before the LLM runs, when the library has no demonstration of one of the primitives ``pids``
    whose generalization answers are to be grounded; ``leave_out`` says how to run without grounding."""
    from taskcond.evaluation import EVAL_OBJECTS
    from taskcond.execution.skills import SkillError
    from taskcond.execution.sources import demonstration_evidence

    try:
        for pid in sorted(pids):
            demonstration_evidence(library, PRIMITIVES[pid].task_name(*EVAL_OBJECTS[pid][0]))
    except SkillError as exc:
        fail(f"{exc}; the grounded column needs it ({leave_out})")
