"""The ``taskcond`` command line: conditions, tasks, oracle runs and evaluations.

Bad input (an unknown task, verb, object, primitive or backend; an LLM that fails) ends with a one-line
``error:`` message on stderr and exit code 2, never a traceback.
"""

from __future__ import annotations

import contextlib
import json
import sys
from collections.abc import Iterable
from dataclasses import asdict, dataclass, replace
from pathlib import Path
from typing import Annotated, NoReturn

import typer

from taskcond import cli_viz
from taskcond.cli_viz import RerunAllOption, RerunEvalOption, RerunRunOption, VideoSizeOption
from taskcond.conditions import ConditionError
from taskcond.generator import PROMPT_VERSION
from taskcond.llm.base import LLMError
from taskcond.primitives import PRIMITIVES, TaskNameError, parse_task
from taskcond.reproduce import CONDITION_COLUMNS, EXECUTION_COLUMNS, GROUNDED_COLUMN

app = typer.Typer(
    help="Long-horizon manipulation guided by LLM-generated task conditions (arXiv 2310.02264).",
    no_args_is_help=True,
    add_completion=False,
    pretty_exceptions_enable=False,
)
eval_app = typer.Typer(
    help="Measure the framework: condition generation/generalization (Table II), primitive and "
    "long-horizon execution (Tables III, IV).",
    no_args_is_help=True,
)
app.add_typer(eval_app, name="eval")

LlmOption = Annotated[
    str | None,
    typer.Option(
        "--llm",
        help="Backend: embedded, embedded:MODEL (qwen2.5-coder-1.5b, qwen2.5-coder-0.5b), openai, "
        "openai:MODEL. Default: $TASKCOND_LLM, the config file, else embedded.",
    ),
]
SamplesOption = Annotated[
    int,
    typer.Option(
        "--samples",
        min=1,
        help="Self-consistency, majority per condition: for a left-out primitive in the code form (v6, v7), "
        "greedy answers over this many example orders; otherwise answers sampled per chat.",
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
        help="Prompt set: v7 (default: v6 whose code chat says a container's state is asserted only "
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
    from dataclasses import replace

    from taskcond.generator import ConditionGenerator, prompt_versions
    from taskcond.llm.config import LLMConfig, make_backend

    if prompt_version not in prompt_versions():
        fail(f"--prompt-version {prompt_version!r}: use one of {', '.join(prompt_versions())}")
    config = LLMConfig.load(llm)
    if no_cache:
        config = replace(config, cache=False)
    return ConditionGenerator(
        make_backend(config), samples=samples, grammar=grammar, prompt_version=prompt_version
    )


@app.command()
def conditions(
    task: Annotated[str, typer.Argument(help='Primitive task name, e.g. "move bottle into box".')],
    as_json: JsonOption = False,
    exclude: Annotated[
        list[str] | None,
        typer.Option(
            "--exclude", help=f"Leave this primitive's examples out (repeatable): {', '.join(PRIMITIVES)}."
        ),
    ] = None,
    llm: LlmOption = None,
    samples: SamplesOption = 1,
    no_cache: NoCacheOption = False,
    grammar: Annotated[
        str,
        typer.Option(
            "--grammar",
            help="Constrained decoding: fallback (only after an invalid answer), always, or never.",
        ),
    ] = "fallback",
    seed: Annotated[int, typer.Option("--seed", help="Sampling seed.")] = 0,
    prompt_version: PromptVersionOption = PROMPT_VERSION,
    ground: Annotated[
        bool,
        typer.Option(
            "--ground",
            help="Ground the answer in the demonstration of its primitive from the skill library (the "
            "suite's, or one learned with `taskcond learn --demo`): the llm+demo condition source.",
        ),
    ] = False,
    explain: Annotated[
        bool,
        typer.Option("--explain", help="With --ground implied: print the LLM's answer and every repair."),
    ] = False,
    skills: Annotated[
        Path | None,
        typer.Option("--skills", help="Skill library for --ground (default: the user cache's)."),
    ] = None,
    primitives: PrimitivesOption = None,
) -> None:
    """Generate the task condition of TASK with the LLM (paper §III-B/C) and print it; with --ground, checked
    against the demonstration of its primitive (beyond the paper)."""
    _declare(primitives)
    try:
        if grammar not in ("fallback", "always", "never"):
            fail(f"--grammar {grammar!r}: use fallback, always or never")
        parse_task(task)
        gen = _generator(llm, samples, no_cache, grammar=grammar, prompt_version=prompt_version)
        result = gen.generate(task, exclude=exclude or (), seed=seed)
    except (TaskNameError, ConditionError, LLMError) as exc:
        fail(str(exc))
    condition, repairs = result.condition, None
    if ground or explain:
        _sim_import()
        from taskcond.execution.skills import SkillError
        from taskcond.execution.sources import demonstration_evidence
        from taskcond.grounding import ground as ground_in

        try:
            grounded = ground_in(condition, demonstration_evidence(_library(skills), task))
        except SkillError as exc:
            fail(str(exc))
        condition, repairs = grounded.condition, grounded.repairs
    if as_json:
        out = condition.to_dict()
        if repairs is not None:
            out |= {"llm": result.condition.to_dict(), "repairs": [r.to_dict() for r in repairs]}
        typer.echo(json.dumps(out, indent=2))
        return
    if explain:
        typer.echo("# the LLM's answer:")
        typer.echo("\n".join(f"#   {line}" for line in result.condition.to_text().splitlines()))
        typer.echo(f"# grounded in the demonstration: {len(repairs or ())} repair(s)")
        for repair in repairs or ():
            typer.echo(f"#   {repair}")
    typer.echo(condition.to_text())
    source = "cache" if result.cached else f"{gen.backend.name}:{gen.backend.model}"
    grounded_note = ", grounded in its demonstration" if repairs is not None else ""
    typer.echo(f"# {result.mode}{grounded_note}, {result.seconds:.2f} s, from {source}", err=True)


@app.command()
def tasks(as_json: JsonOption = False, primitives: PrimitivesOption = None) -> None:
    """List the primitives with their task-name patterns and the suite's tasks (--json: the suite's tasks)."""
    _declare(primitives)
    try:
        from taskcond.tasks.registry import list_tasks

        suite = list_tasks()
    except ImportError:
        suite = []
    if as_json:
        rows = []
        for t in suite:
            row = {"id": t.id, "kind": t.kind, "primitive": t.primitive, "objects": list(t.objects)}
            if t.kind == "long-horizon":  # its primitives in order, and the primitive tasks they come from
                row["primitive"] = [parse_task(step).primitive.id for step in t.primitive]
                row["steps"] = list(t.primitive)
            rows.append(row)
        if not suite:
            typer.echo("(no suite tasks: the task suite needs pip install 'taskcond[sim]')", err=True)
        typer.echo(json.dumps(rows, indent=2))
        return
    typer.echo("Primitives (id: pattern; aliases):")
    for p in PRIMITIVES.values():
        aliases = f"; {', '.join(p.aliases)}" if p.aliases else ""
        typer.echo(f"  {p.id:14s} {p.pattern}{aliases}{' (declared)' if p.declared else ''}")
    if suite:
        typer.echo("\nSuite tasks (id: objects or primitive tasks):")
        for t in suite:
            detail = ", ".join(t.objects) if t.kind == "primitive" else " -> ".join(t.primitive)
            typer.echo(f"  {t.id:32s} {detail}")
    else:
        typer.echo("\n(the PyBullet task suite needs the [sim] extra: pip install 'taskcond[sim]')")


@app.command()
def oracle(
    task: Annotated[
        str, typer.Argument(help="Suite task id (see `taskcond tasks`), e.g. grasp-bottle or LHT1.")
    ],
    episodes: Annotated[int, typer.Option("--episodes", min=1, help="Number of seeded episodes.")] = 10,
    seed: Annotated[
        int, typer.Option("--seed", help="Seed of the first episode; episode k uses seed + k.")
    ] = 0,
    as_json: JsonOption = False,
    video: Annotated[
        Path | None, typer.Option("--video", help="Record the first episode to this .mp4 or .gif.")
    ] = None,
) -> None:
    """Run the scripted oracle of TASK and report its success rate."""
    try:
        from taskcond.tasks.oracle import run_oracle
    except ImportError as exc:
        fail(f"the task suite needs the [sim] extra ({exc.name} missing): pip install 'taskcond[sim]'")
    if video is not None and video.suffix.lower() not in (".mp4", ".gif"):
        fail(f"--video {video}: use a .mp4 or .gif file name")
    try:
        report = run_oracle(task, episodes=episodes, seed=seed, video=video)
    except ValueError as exc:
        fail(str(exc))
    out = {
        "task": report.task,
        "episodes": report.episodes,
        "successes": report.successes,
        "steps_per_second": round(report.steps_per_second, 1),
        "failures": dict(report.failures),
        "failed_seeds": report.failed_seeds,
    }
    if as_json:
        typer.echo(json.dumps(out))
    else:
        typer.echo(
            f"{report.task}: {report.successes}/{report.episodes} succeeded "
            f"({report.steps_per_second:.0f} steps/s); failures: {dict(report.failures) or 'none'}"
            + (f" (seeds {', '.join(map(str, report.failed_seeds))})" if report.failed_seeds else "")
        )


@eval_app.command("conditions")
def eval_conditions(
    trials: Annotated[int, typer.Option("--trials", min=1, help="Trials per primitive and mode.")] = 5,
    as_json: JsonOption = False,
    llm: LlmOption = None,
    samples: SamplesOption = 1,
    no_cache: NoCacheOption = False,
    primitive: Annotated[
        list[str] | None,
        typer.Option("--primitive", help=f"Only these primitives (repeatable): {', '.join(PRIMITIVES)}."),
    ] = None,
    prompt_version: PromptVersionOption = PROMPT_VERSION,
    probe: Annotated[
        bool,
        typer.Option(
            "--probe/--no-probe",
            help="Also ask the model the zero-shot state probe (46 yes/no questions, cached) and print its "
            "score beside the generalization figure.",
        ),
    ] = True,
    mode: Annotated[
        list[str] | None,
        typer.Option(
            "--mode", help="Only these modes (repeatable): generation, generalization. Default both."
        ),
    ] = None,
    grounded: Annotated[
        bool | None,
        typer.Option(
            "--grounded/--no-grounded",
            help="Also ground every generalization answer in the suite's demonstration of its primitive "
            "(column 'generalization, grounded'; needs the [sim] extra and the skill library, learned on "
            "first use). Default: when the [sim] extra is installed.",
        ),
    ] = None,
    skills: SkillsOption = None,
) -> None:
    """Generation (all examples) and generalization (leave-one-out) accuracy per primitive (Table II),
    generalization grounded in the demonstrations, and the model's zero-shot state probe."""
    from tqdm import tqdm

    from taskcond.evaluation import evaluate_conditions
    from taskcond.primitives import get_primitive
    from taskcond.results import RunConfig, code_version, llm_fields

    modes = mode or ["generation", "generalization"]
    bad = [m for m in modes if m not in ("generation", "generalization")]
    if bad:
        fail(f"--mode {bad[0]!r}: use generation or generalization")
    try:
        pids = [get_primitive(p).id for p in primitive] if primitive else list(PRIMITIVES)
        gen = _generator(llm, samples, no_cache, prompt_version=prompt_version)
    except (TaskNameError, LLMError) as exc:
        fail(str(exc))
    if grounded is None:
        import importlib.util

        grounded = importlib.util.find_spec("pybullet") is not None
        if not grounded:
            typer.echo(
                "(no 'generalization, grounded' column: it needs pip install 'taskcond[sim]')", err=True
            )
    evidence = None
    if grounded and "generalization" in modes:
        from taskcond.execution.sources import demonstration_evidence

        _sim_import()
        library = _library(skills)
        _require_demonstrations(library, pids, "or leave the column out: --no-grounded")

        def evidence(task):
            return demonstration_evidence(library, task.name)

    total = len(modes) * trials * len(pids)
    bar = tqdm(total=total, desc="conditions", unit="cond", file=sys.stderr, disable=None)
    result = evaluate_conditions(
        gen, trials=trials, primitives=pids, modes=modes, progress=lambda _o: bar.update(), evidence=evidence
    )
    bar.close()
    config = RunConfig(kind="conditions", **llm_fields(llm, gen), code=code_version())
    if probe:
        from taskcond.probe import probe as state_probe

        try:  # beside the generalization figure: does the model know the primitives' states at all?
            result.probe = state_probe(gen.backend)
        except LLMError as exc:
            typer.echo(f"state probe not measured: {exc}", err=True)
    if as_json:
        made = {"config": config.to_dict(), "digest": config.digest}
        typer.echo(json.dumps(result.to_dict() | made, indent=2))
    else:
        typer.echo(result.table())
        medians = ", ".join(f"{m} {result.median_seconds(m):.2f}" for m in modes)
        typer.echo(
            f"\nmodel {result.model}; prompts {result.prompt_version}, samples {result.samples}; median "
            f"seconds per condition: {medians}; configuration {config.digest} (code {config.code})"
        )
        if result.probe is not None:
            typer.echo(
                f"{result.probe.summary()}: zero-shot yes/no questions on the primitives' object states "
                "(benchmarks/probe_llm.py); near chance, the model cannot know a left-out primitive's states"
            )
        if result.grounded:
            extra = sum(len(o.extra_relations) for o in result.outcomes)
            incidental = sum(len(o.incidental) for o in result.outcomes)
            repairs = sum(len(o.repairs) for o in result.outcomes)
            typer.echo(
                f"grounded in the suite's demonstrations: {repairs} repairs; relations beyond the reference "
                f"in grounded answers: {extra} ({incidental} added by grounding)"
            )


def _sim_import() -> None:
    try:
        import pybullet  # noqa: F401
    except ImportError as exc:
        fail(f"execution needs the [sim] extra ({exc.name} missing): pip install 'taskcond[sim]'")


def _library(skills: Path | None):
    from taskcond.execution.runner import default_library_dir, load_library
    from taskcond.execution.skills import SkillError

    def told(task_id: str, ok: bool) -> None:
        typer.echo(f"  demonstrated {task_id}{'' if ok else ' (oracle failed; kept anyway)'}", err=True)

    directory = skills or default_library_dir()
    if not (directory / "library.json").exists():
        typer.echo(f"learning the skill library into {directory} (once, about a minute)", err=True)
    try:
        return load_library(directory, progress=told)
    except SkillError as exc:
        fail(str(exc))


@app.command()
def learn(
    out: Annotated[
        Path | None, typer.Option("--out", help="Directory of the library (default: the user cache).")
    ] = None,
    task: Annotated[
        list[str] | None,
        typer.Option(
            "--task", help="Only these suite tasks (repeatable; default all primitives and LHT1-LHT4)."
        ),
    ] = None,
    seed: Annotated[int, typer.Option("--seed", help="Seed of the first demonstration of each task.")] = 0,
    demo: Annotated[
        list[Path] | None,
        typer.Option(
            "--demo",
            help="Learn from this demonstration file instead (repeatable; format in the README, "
            "`taskcond record` writes one): its skill is added to the library.",
        ),
    ] = None,
    primitives: PrimitivesOption = None,
    method: Annotated[
        str,
        typer.Option(
            "--method",
            help="What to learn: dmp (the skill library) or image-il (the image-based imitation-learning "
            "baseline: oracle demonstrations rendered, a policy trained; needs the il extra, about 45 min "
            "on one core).",
        ),
    ] = "dmp",
) -> None:
    """Record oracle demonstrations and store the skill library: DMPs and FromEnv conditions (§III-D); or
    learn the skills of demonstration files (--demo); or train the image-based baseline (--method
    image-il)."""
    _sim_import()
    _declare(primitives)
    if method not in ("dmp", "image-il"):
        fail(f"--method {method!r}: use dmp or image-il")
    if method == "image-il":
        if demo or task or out:
            fail(
                "--method image-il learns from the suite's oracles into the cache; --demo, --task and --out "
                "do not apply"
            )
        _il_policy(learn_if_missing=True)
        return
    from tqdm import tqdm

    from taskcond.execution.kitchen import CONTEXTS, learn_library, primitive_task_ids
    from taskcond.execution.runner import default_library_dir
    from taskcond.tasks.registry import UnknownTaskError, get_task

    if demo:
        if task:
            fail("give either --task (oracle demonstrations) or --demo (demonstration files), not both")
        _learn_files(demo, out)
        return
    ids = task or [*primitive_task_ids(), *CONTEXTS]
    try:
        for tid in ids:
            get_task(tid)
    except UnknownTaskError as exc:
        fail(str(exc))
    directory = out or default_library_dir()
    bar = tqdm(total=len(ids), desc="demonstrations", unit="task", file=sys.stderr, disable=None)
    failed: list[str] = []

    def told(task_id: str, ok: bool) -> None:
        bar.update()
        if not ok:
            failed.append(task_id)

    try:
        library = learn_library(directory, ids, seed=seed, progress=told)
    except ValueError as exc:
        fail(str(exc))
    bar.close()
    typer.echo(f"{len(library)} skills from {len(ids)} tasks in {directory}")
    if failed:
        typer.echo(f"oracle failed on every try for: {', '.join(failed)} (their last try was kept)", err=True)


def _il_policy(learn_if_missing: bool = True) -> Path:
    """The directory of the baseline's checkpoint (default specs), trained first with progress bars when
    missing and ``learn_if_missing``; exit 2 with one line when the [il] extra is missing."""
    from tqdm import tqdm

    from taskcond.il import ILUnavailableError, require_il
    from taskcond.il.config import TrainSpec, data_dir, policy_dir
    from taskcond.il.dataset import DataSpec, collect

    try:
        require_il()
    except ILUnavailableError as exc:
        fail(str(exc))
    directory = policy_dir()
    if (directory / "policy.json").exists():
        typer.echo(f"image-il policy: {directory}", err=True)
        return directory
    if not learn_if_missing:
        fail(f"no image-il policy in {directory}; train it with `taskcond learn --method image-il`")
    from taskcond.execution.kitchen import CONTEXTS, primitive_task_ids
    from taskcond.il.train import learn_policy

    data, spec = DataSpec(), TrainSpec()
    ids = [*primitive_task_ids(), *CONTEXTS]
    typer.echo(f"training the image-il policy into {directory} (once, about 45 min on one core)", err=True)
    bar = tqdm(
        total=sum(map(data.episodes_of, ids)),
        desc="demonstrations",
        unit="demo",
        file=sys.stderr,
        disable=None,
    )
    try:
        samples = collect(data_dir(data), ids, data, lambda _task: bar.update())
    except RuntimeError as exc:
        fail(str(exc))
    bar.close()
    bar = tqdm(total=spec.steps, desc="training", unit="step", file=sys.stderr, disable=None)

    def told(step: int, loss: float) -> None:
        bar.update(step - bar.n)
        bar.set_postfix(loss=f"{loss:.4f}")

    _, history = learn_policy(directory, samples, data, spec, told)
    bar.close()
    typer.echo(
        f"image-il policy: {len(samples)} samples of {len(samples.names)} primitive task names, "
        f"{spec.steps} steps in {history['seconds'] / 60:.1f} min, final loss {history['loss'][-1]:.4f}; "
        f"{directory}"
    )
    return directory


def _learn_files(files: list[Path], out: Path | None) -> None:
    """``taskcond learn --demo``: replay each file in its scene, learn its skill, add it to the library."""
    from taskcond.execution.demofile import DemoFileError, load_trajectory
    from taskcond.execution.kitchen import replay_demonstration
    from taskcond.execution.skills import SkillLibrary, learn_skill

    # a new --out directory holds just these skills; the default library gets the oracles' skills first
    fresh = out is not None and not (out / "library.json").exists()
    library = SkillLibrary() if fresh else _library(out)
    directory = out or _default_library_dir()
    for path in files:
        try:
            demonstration = replay_demonstration(load_trajectory(path))
            skill = learn_skill(demonstration)
        except (DemoFileError, ValueError) as exc:
            fail(str(exc))
        library.add(skill)
        cond = skill.condition
        typer.echo(
            f"learned {skill.task_id} ({skill.primitive}, DMP pieces: {len(skill.segments)}, "
            f"{skill.duration:.1f} s) from {path}"
        )
        if skill.evidence is not None and cond is not None:
            typer.echo(
                f"  FromEnv: pre [{', '.join(map(str, cond.pre_conditions))}] post "
                f"[{', '.join(map(str, cond.post_conditions))}]"
            )
    library.save(directory)
    typer.echo(f"{len(library)} skills in {directory}")


def _default_library_dir() -> Path:
    from taskcond.execution.runner import default_library_dir

    return default_library_dir()


@app.command()
def record(
    task: Annotated[
        str, typer.Argument(help="Suite primitive task id (see `taskcond tasks`), e.g. grasp-bottle.")
    ],
    out: Annotated[Path, typer.Option("--out", help="Demonstration file to write (.json).")],
    seed: Annotated[int, typer.Option("--seed", help="Seed of the scene.")] = 0,
) -> None:
    """Record the oracle of a suite primitive task as a demonstration file (what `learn --demo` reads)."""
    _sim_import()
    from taskcond.execution.kitchen import record_trajectory

    if out.suffix.lower() != ".json":
        fail(f"--out {out}: a demonstration file is .json")
    try:
        recorded, ok = record_trajectory(task, seed)
    except ValueError as exc:
        fail(str(exc))
    recorded.save(out)
    typer.echo(
        f"{out}: {recorded.task_name!r}, {len(recorded.times)} samples, {recorded.times[-1]:.1f} s"
        + ("" if ok else " (the oracle failed on this seed)")
    )
    if not ok:
        raise typer.Exit(1)


def _slug(text: str) -> str:
    return "-".join("".join(c if c.isalnum() else " " for c in text.lower()).split())[:60] or "run"


@app.command()
def run(
    spec: Annotated[
        str,
        typer.Argument(
            help='A suite task id (LHT1, grasp-bottle), a primitive task ("open box") or a free '
            'instruction ("pick up the bottle, put it into the box and close the box").'
        ),
    ],
    method: MethodOption = "llm",
    seed: Annotated[int, typer.Option("--seed", help="Seed of the scene and of the perception noise.")] = 0,
    video: Annotated[
        Path | None,
        typer.Option("--video", help="Video (.mp4/.gif); default runs/<task>-<method>-<seed>.mp4."),
    ] = None,
    no_video: Annotated[bool, typer.Option("--no-video", help="Do not record a video.")] = False,
    size: VideoSizeOption = "640x480",
    rerun: RerunRunOption = None,
    trace: Annotated[
        Path | None, typer.Option("--trace", help="JSON trace; default runs/<task>-<method>-<seed>.json.")
    ] = None,
    gui: Annotated[bool, typer.Option("--gui", help="Show the PyBullet GUI.")] = False,
    noise: NoiseOption = 0.005,
    llm: LlmOption = None,
    skills: SkillsOption = None,
    planner: PlannerOption = "conditions",
    start: StartOption = "task",
    primitives: PrimitivesOption = None,
) -> None:
    """Perform a long-horizon task: conditions, the look-ahead planner, Alg. 1 pre-condition satisfaction,
    Alg. 2 DMP control; a free instruction is judged by its goal predicates (exit 0 only on success)."""
    _sim_import()
    _declare(primitives)
    from taskcond.execution.decompose import DecompositionError
    from taskcond.execution.executor import METHODS
    from taskcond.execution.kitchen import STARTS, scene_objects
    from taskcond.execution.runner import (
        PLANNERS,
        default_library_dir,
        execution_config,
        llm_decomposer,
        make_source,
        plan_run,
        refused_task,
        run_episode,
    )

    if method not in METHODS:
        fail(f"--method {method!r}: use one of {', '.join(METHODS)}")
    if planner not in PLANNERS:
        fail(f"--planner {planner!r}: use one of {', '.join(PLANNERS)}")
    if start not in STARTS:
        fail(f"--start {start!r}: use one of {', '.join(STARTS)}")
    if video is not None and video.suffix.lower() not in (".mp4", ".gif"):
        fail(f"--video {video}: use a .mp4 or .gif file name")
    video_size = cli_viz.video_size(size)
    cli_viz.rerun_ready(rerun)

    def announce(scene: str) -> None:
        typer.echo(f"decomposing the instruction with the LLM ({scene} scene) ...", err=True)

    try:
        plan = plan_run(spec, llm_decomposer(llm, announce))
    except (DecompositionError, LLMError, ValueError) as exc:
        fail(str(exc))
    if plan.task_id is None and not plan.decomposed:  # one primitive task the suite does not have
        refused = refused_task(spec, *scene_objects(plan.scene))
        if refused is not None:
            fail(f"{refused}; nothing was run")
    typer.echo(f"task: {plan.label}" + (" (decomposed by the LLM)" if plan.decomposed else ""))
    for k, step in enumerate(plan.steps, start=1):
        typer.echo(f"  {k}. {step}")
    library = _library(skills)
    try:
        source = make_source(method, library, llm)  # type: ignore[arg-type]
    except (LLMError, ValueError) as exc:
        fail(str(exc))
    where = "" if start == "task" else f"-{start}"
    stem = Path("runs") / f"{_slug(plan.label)}-{method}{where}-{seed}"
    video_path = None if no_video else (video or stem.with_suffix(".mp4"))
    trace_path = trace or stem.with_suffix(".json")

    def show(event) -> None:
        typer.echo(f"{event.time:7.2f}s {'  ' * event.depth}{event.message}")

    def planned(repair, goal) -> None:
        if repair is not None and repair.changes:
            typer.echo("plan repaired by the planner:")
            for k, step in enumerate(repair.steps, start=1):
                typer.echo(f"  {k}. {step}")
            for change in repair.changes:
                typer.echo(f"  - {change}")
        elif repair is not None and repair.impossible is None:
            typer.echo("plan checked by the planner: no change")
        for left in () if repair is None else repair.unresolved:
            typer.echo(f"  (left to Alg. 1: {left})")
        typer.echo(f"goal: {', '.join(map(str, goal)) or 'none (no predicate to check)'}")

    config = execution_config(skills or default_library_dir(), noise, llm, planner=planner, start=start)
    result = run_episode(
        plan,
        method,  # type: ignore[arg-type]
        seed,
        library,
        source,
        noise,
        video_path,
        gui,
        show,
        planner=planner,
        on_plan=planned,
        start_state=start,
        video_size=video_size,
        observers=cli_viz.run_observers(rerun),
    )
    trace_path.parent.mkdir(parents=True, exist_ok=True)
    trace_path.write_text(
        json.dumps(
            {
                "plan": {
                    "label": plan.label,
                    "task_id": plan.task_id,
                    "steps": list(plan.steps),
                    "scene": plan.scene,
                }
            }
            | {"config": config.to_dict(), "digest": config.digest}
            | asdict(result),
            indent=1,
        ),
        encoding="utf-8",
    )
    if result.failure == "impossible":
        fail(f"cannot do {plan.label!r}: {result.reason}; nothing moved (trace: {trace_path})")
    outcome = "succeeded" if result.success else f"FAILED ({result.reason})"
    typer.echo(
        f"{plan.label}: {outcome}; {result.sim_seconds:.1f} s simulated, {result.wall_seconds:.1f} s wall"
    )
    typer.echo(
        f"trace: {trace_path}"
        + (f"; video: {video_path}" if video_path else "")
        + (f"; recording: {rerun} (open with `rerun {rerun}`)" if rerun else "")
    )
    if not result.success:
        raise typer.Exit(1)


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


def _run_episodes(
    jobs, out: Path, settings: ExecutionSettings, desc: str, instructions: Path | None = None
) -> tuple[list[dict], dict]:
    """Run ``jobs`` into the results file ``out`` (resuming it) with a progress bar; returns the results
    and the run's configuration (with its digest). A job's task is a suite id, or with ``instructions``
    (an instructions file, already checked) an instruction's id: every instruction is decomposed here
    first (the LLM's answers cached for the workers). Ends with exit 2 when ``out`` holds another
    configuration; crashed episodes are reported on stderr and left out (the next call runs them again),
    see :func:`_crashed`."""
    from tqdm import tqdm

    from taskcond.execution.runner import (
        BACKENDS,
        IMAGE_IL,
        PLANNERS,
        cpu_count,
        default_library_dir,
        evaluate,
        execution_config,
        make_source,
        novel_primitive_source,
        plan_run,
    )
    from taskcond.results import ConfigMismatchError, Job, ResultsFile

    if settings.backend not in BACKENDS:
        fail(f"--backend {settings.backend!r}: use one of {', '.join(BACKENDS)}")
    if settings.planner not in PLANNERS:
        fail(f"--planner {settings.planner!r}: use one of {', '.join(PLANNERS)}")
    cli_viz.rerun_ready(settings.rerun, suffix=None)
    library_dir = settings.skills or default_library_dir()
    library = _library(settings.skills) if any(j.method != IMAGE_IL for j in jobs) else None
    il_dir = _il_policy() if any(j.method == IMAGE_IL for j in jobs) else None
    try:
        config = execution_config(
            library_dir if library is not None else None,
            settings.noise,
            settings.llm,
            planner=settings.planner,
            start=settings.start,
            instructions=instructions,
            il_dir=il_dir,
            novel_primitive=settings.novel_primitive,
        )
        results = ResultsFile(out, config)
    except (ConfigMismatchError, LLMError) as exc:
        fail(str(exc))
    done = results.done(Job.key_of)
    todo = [j for j in jobs if j.key not in done]
    steps = _instruction_steps(instructions, {j.task for j in todo}, settings.llm) if instructions else {}
    llms = [m for m in ("llm", "llm+demo") if any(j.method == m for j in todo)]
    for method in llms:  # every condition once here; the workers read the cache
        try:
            source = make_source(method, library, settings.llm)  # type: ignore[arg-type]
            if settings.novel_primitive:  # one draw per episode; a draw without an answer fails its episode
                for job in tqdm(
                    [j for j in todo if j.method == method],
                    desc="conditions",
                    unit="episode",
                    file=sys.stderr,
                    disable=None,
                ):
                    drawn, _ = novel_primitive_source(source, job.task, job.seed)  # type: ignore[arg-type]
                    for name in plan_run(job.task).steps:
                        with contextlib.suppress(LLMError):
                            drawn.condition(name)
                continue
            names = {
                s
                for j in todo
                if j.method == method
                for s in (steps.get(j.task, ()) if instructions else plan_run(j.task).steps)
            }
            for name in tqdm(sorted(names), desc="conditions", unit="task", file=sys.stderr, disable=None):
                source.condition(name)  # type: ignore[union-attr]
        except (LLMError, TaskNameError, ConditionError, ValueError) as exc:
            fail(str(exc))
    bar = tqdm(total=len(jobs), desc=desc, unit="episode", file=sys.stderr, disable=None)
    bar.update(len(jobs) - len(todo))
    crashed: list[dict] = []

    def told(rec: dict) -> None:
        bar.update()
        if rec.get("crashed"):
            crashed.append(rec)

    try:
        records = evaluate(
            jobs,
            results,
            library_dir,
            settings.workers or cpu_count(),
            settings.llm,
            settings.noise,
            progress=told,
            planner=settings.planner,
            backend=settings.backend,
            ray_address=settings.ray_address,
            start=settings.start,
            instructions=instructions,
            il_dir=il_dir,
            novel_primitive=settings.novel_primitive,
            rerun=settings.rerun,
            rerun_all=settings.rerun_all,
        )
    except RuntimeError as exc:  # Ray missing or unreachable
        fail(str(exc))
    bar.close()
    _crashed(crashed)
    ran = {j.key for j in todo}
    kept = [r["rerun"] for r in records if r.get("rerun") and Job.key_of(r) in ran]
    if settings.rerun is not None:
        typer.echo(f"{len(kept)} recording(s) in {settings.rerun} (open one with `rerun FILE.rrd`)", err=True)
    config = results.config
    return records, config.to_dict() | {"digest": config.digest, "crashed": len(crashed)}


def _instruction_steps(path: Path, ids: set[str], llm: str | None) -> dict[str, tuple[str, ...]]:
    """Instruction id → its primitive tasks, for the instructions of ``path`` among ``ids``: the LLM's
    decomposition, asked once here (cached; the workers read the cache). An instruction the LLM gives no
    plan for is left out: its episodes record the failure."""
    from tqdm import tqdm

    from taskcond.execution.decompose import DecompositionError
    from taskcond.execution.runner import instruction_plan, llm_decomposer
    from taskcond.instructions import load_instructions

    decomposer = llm_decomposer(llm)
    chosen = [i for i in load_instructions(path) if i.id in ids]
    steps = {}
    for ins in tqdm(chosen, desc="decomposing", unit="instruction", file=sys.stderr, disable=None):
        try:
            steps[ins.id] = instruction_plan(ins.text, decomposer).steps
        except DecompositionError:
            continue
        except LLMError as exc:
            fail(str(exc))
    return steps


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
    from taskcond.execution.kitchen import STARTS

    if start not in STARTS:
        fail(f"--start {start!r}: use one of {', '.join(STARTS)}")


def _eval_execution(
    kind: str,
    episodes: int,
    method: list[str] | None,
    as_json: bool,
    out: Path | None,
    task: list[str] | None,
    seed: int,
    settings: ExecutionSettings,
) -> None:
    _sim_import()
    from taskcond.execution.runner import EVAL_METHODS, NOVEL_METHODS, eval_task_ids, jobs_for, summarize

    novel = settings.novel_primitive
    if novel and kind != "long-horizon":
        fail("--novel-primitive applies to `taskcond eval long-horizon` only")
    methods = method or (list(NOVEL_METHODS) if novel else ["llm", "env", "none"])
    valid = NOVEL_METHODS if novel else EVAL_METHODS
    bad = [m for m in methods if m not in valid]
    if bad:
        what = " with --novel-primitive (its conditions come from the LLM)" if novel else ""
        fail(f"--method {bad[0]!r}{what}: use one of {', '.join(valid)}")
    if "image-il" in methods and settings.start != "task":
        fail(
            "--method image-il runs from the tasks' own start states only (it was trained on them): "
            "use --start task"
        )
    ids = eval_task_ids(kind)
    if task:
        unknown = [t for t in task if t not in ids]
        if unknown:
            fail(f"{unknown[0]!r} is not a {kind} task of the evaluation; valid: {', '.join(ids)}")
        ids = task
    jobs = jobs_for(ids, methods, episodes, seed)
    where = ("" if settings.start == "task" else f"-{settings.start}") + ("-novel-primitive" if novel else "")
    out = out or Path("runs") / f"eval-{kind}{where}.jsonl"
    records, config = _run_episodes(jobs, out, settings, kind)
    if config["crashed"]:
        raise typer.Exit(1)
    rows = summarize(records)
    walls = [r["wall_seconds"] for r in records if "wall_seconds" in r]
    if as_json:
        typer.echo(json.dumps({"results": rows}, indent=2))
        return
    if novel:
        _print_novel(rows, records)
    else:
        typer.echo(f"{'task':34s} {'method':8s} {'success':>9s}  failures")
        for row in rows:
            rate = f"{row['successes']}/{row['episodes']}"
            typer.echo(f"{row['task']:34s} {row['method']:8s} {rate:>9s}  {row['failures'] or ''}")
    if walls:
        typer.echo(
            f"\n{len(records)} episodes in {out}; {60.0 / (sum(walls) / len(walls)):.1f} episodes per minute "
            f"per core (mean episode wall time); configuration {config['digest']} (code {config['code']})"
        )


def _print_novel(rows: list[dict], records: list[dict]) -> None:
    """The novel-primitive table: per task and method the successes, per left-out primitive
    (successes/episodes), and each failure's seed, left-out primitive and reason."""
    typer.echo(f"{'task':6s} {'method':9s} {'success':>8s}  by left-out primitive")
    for row in rows:
        rate = f"{row['successes']}/{row['episodes']}"
        parts = [f"{p} {v['successes']}/{v['episodes']}" for p, v in sorted(row.get("left_out", {}).items())]
        typer.echo(f"{row['task']:6s} {row['method']:9s} {rate:>8s}  {', '.join(parts)}")
    failed = sorted(
        (r for r in records if not r.get("success")), key=lambda r: (r["task"], r["method"], r["seed"])
    )
    if failed:
        typer.echo("\nfailures (task, method, seed, left out: reason):")
    for r in failed:
        reason = " ".join(str(r.get("reason") or r.get("failure")).split())[:110]
        typer.echo(f"  {r['task']} {r['method']} {r['seed']}, {r.get('left_out')} left out: {reason}")


def _eval_command(kind: str):
    def command(
        episodes: Annotated[
            int, typer.Option("--episodes", min=1, help="Seeded episodes per task and method.")
        ] = 10,
        method: Annotated[
            list[str] | None,
            typer.Option(
                "--method",
                help="Methods to compare (repeatable): llm, llm+demo, env, none, image-il (the image-based "
                "imitation-learning baseline; needs the il extra). Default llm, env, none (with "
                "--novel-primitive: llm, llm+demo).",
            ),
        ] = None,
        workers: WorkersOption = None,
        as_json: JsonOption = False,
        out: Annotated[
            Path | None,
            typer.Option(
                "--out",
                help="JSON-lines results, appended per episode; it records the configuration, and a run "
                "with the same configuration resumes from it (another configuration is an error). "
                "Default runs/eval-primitives.jsonl, runs/eval-long-horizon.jsonl or "
                "runs/eval-long-horizon-novel-primitive.jsonl.",
            ),
        ] = None,
        task: Annotated[
            list[str] | None, typer.Option("--task", help="Only these suite task ids (repeatable).")
        ] = None,
        seed: Annotated[int, typer.Option("--seed", help="Seed of the first episode of each task.")] = 1000,
        noise: NoiseOption = 0.005,
        llm: LlmOption = None,
        skills: SkillsOption = None,
        planner: PlannerOption = "conditions",
        start: StartOption = "task",
        backend: BackendOption = "local",
        ray_address: RayAddressOption = None,
        novel_primitive: Annotated[
            bool,
            typer.Option(
                "--novel-primitive",
                help="Long-horizon tasks only: Table IV's novel primitive tasks: each episode leaves one "
                "primitive of its task, drawn from the episode's seed, out of the LLM's examples "
                "(generalization, example order seeded by the episode). Methods llm and llm+demo (default "
                "both).",
            ),
        ] = False,
        rerun: RerunEvalOption = None,
        rerun_all: RerunAllOption = False,
    ) -> None:
        _check_start(start)
        settings = ExecutionSettings(
            workers,
            noise,
            llm,
            skills,
            backend,
            ray_address,
            planner,
            start,
            novel_primitive=novel_primitive,
            rerun=rerun,
            rerun_all=rerun_all,
        )
        _eval_execution(kind, episodes, method, as_json, out, task, seed, settings)

    return command


@eval_app.command("instructions")
def eval_instructions(
    file: Annotated[
        Path | None,
        typer.Option(
            "--file",
            help="Instructions with their goal predicates (TOML; format in taskcond.instructions). Default: "
            "the package's benchmark (data/instructions.toml).",
        ),
    ] = None,
    episodes: Annotated[int, typer.Option("--episodes", min=1, help="Seeded episodes per instruction.")] = 10,
    method: Annotated[
        list[str] | None,
        typer.Option(
            "--method", help="Methods to compare (repeatable): llm, llm+demo, env, none. Default llm."
        ),
    ] = None,
    instruction: Annotated[
        list[str] | None, typer.Option("--instruction", help="Only these instruction ids (repeatable).")
    ] = None,
    workers: WorkersOption = None,
    as_json: JsonOption = False,
    out: Annotated[
        Path | None,
        typer.Option(
            "--out",
            help="JSON-lines results, appended per episode; a run with the same configuration (the "
            "instructions file's digest included) resumes from it. Default "
            "runs/eval-instructions[-random].jsonl.",
        ),
    ] = None,
    seed: Annotated[
        int, typer.Option("--seed", help="Seed of the first episode of each instruction.")
    ] = 1000,
    start: StartOption = "task",
    noise: NoiseOption = 0.005,
    llm: LlmOption = None,
    skills: SkillsOption = None,
    planner: PlannerOption = "conditions",
    backend: BackendOption = "local",
    ray_address: RayAddressOption = None,
    rerun: RerunEvalOption = None,
    rerun_all: RerunAllOption = False,
) -> None:
    """Free instructions from random starts (beyond the paper): each decomposed by the LLM (cached) as in
    `taskcond run`, run per method, judged by its shipped goal predicates (ground truth); the record also
    says whether the goal the plan itself implies held."""
    _sim_import()
    from taskcond.execution.executor import METHODS
    from taskcond.execution.kitchen import instruction_scene, scene_objects
    from taskcond.execution.runner import jobs_for, summarize
    from taskcond.instructions import InstructionError, check_objects, default_file, load_instructions

    _check_start(start)
    methods = method or ["llm"]
    bad = [m for m in methods if m not in METHODS]
    if bad:
        fail(f"--method {bad[0]!r}: use one of {', '.join(METHODS)}")
    path = file or default_file()
    try:
        chosen = load_instructions(path)
    except InstructionError as exc:
        fail(str(exc))
    for ins in chosen:
        objects, _ = scene_objects(instruction_scene(ins.text))
        reason = check_objects(ins, objects, ("gripper", "kinova gripper"))
        if reason is not None:
            fail(f"{path}: {reason}")
    if instruction:
        ids = [i.id for i in chosen]
        unknown = [i for i in instruction if i not in ids]
        if unknown:
            fail(f"no instruction {unknown[0]!r} in {path}; valid: {', '.join(ids)}")
        chosen = [i for i in chosen if i.id in instruction]
    jobs = jobs_for([i.id for i in chosen], methods, episodes, seed)
    where = "" if start == "task" else f"-{start}"
    out = out or Path("runs") / f"eval-instructions{where}.jsonl"
    settings = ExecutionSettings(
        workers, noise, llm, skills, backend, ray_address, planner, start, rerun=rerun, rerun_all=rerun_all
    )
    records, config = _run_episodes(jobs, out, settings, "instructions", instructions=path.resolve())
    if config["crashed"]:
        raise typer.Exit(1)
    rows = summarize(records)
    by_id = {i.id: i for i in chosen}
    for row in rows:
        recs = [r for r in records if r["task"] == row["task"] and r["method"] == row["method"]]
        row["instruction"] = by_id[row["task"]].text
        row["goal"] = [str(q) for q in by_id[row["task"]].goal]
        row["steps"] = recs[0].get("steps", []) if recs else []
        row["plan_goal_held"] = sum(bool(r.get("plan_goal_held")) for r in recs)
        row["reasons"] = sorted({r["reason"] for r in recs if not r.get("success") and r.get("reason")})
    total = {
        m: [sum(r[k] for r in rows if r["method"] == m) for k in ("successes", "episodes")] for m in methods
    }
    if as_json:
        typer.echo(json.dumps({"results": rows, "total": total, "config": config}, indent=2))
        return
    typer.echo(f"{'instruction':30s} {'method':6s} {'success':>7s} {'plan':>5s}  failures")
    for row in rows:
        rate = f"{row['successes']}/{row['episodes']}"
        held = row["plan_goal_held"]
        typer.echo(f"{row['task']:30s} {row['method']:6s} {rate:>7s} {held:>5d}  {row['failures'] or ''}")
    for m, (ok, n) in total.items():
        typer.echo(f"\n{m}: {ok}/{n} episodes reached their goal ({100 * ok / max(n, 1):.0f}%)")
    typer.echo(
        f"'plan': episodes whose plan's own derived goal held. {len(records)} episodes in {out}; "
        f"configuration {config['digest']} (code {config['code']}, start {start}, planner {planner})"
    )


eval_app.command("primitives", help="Success rate of every primitive task per execution method (Table III).")(
    _eval_command("primitives")
)
eval_app.command(
    "long-horizon", help="Success rate of the long-horizon tasks per execution method (Table IV)."
)(_eval_command("long-horizon"))


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


def _reproduce_conditions(spec, trials, out: Path, llm: str | None, skills: Path | None):
    """Table II's trials into ``out`` (resuming it); returns the results and the configuration."""
    from tqdm import tqdm

    from taskcond.execution.runner import default_library_dir
    from taskcond.reproduce import condition_trial_runner
    from taskcond.results import (
        ConfigMismatchError,
        Job,
        ResultsFile,
        RunConfig,
        code_version,
        directory_digest,
        llm_fields,
    )

    library = _library(skills)
    library_dir = skills or default_library_dir()
    grounded = {t.task for t in trials if t.method == "generalization-grounded"}
    _require_demonstrations(library, grounded, "or leave it out with --column or --row")
    try:
        config = RunConfig(
            kind="conditions", **llm_fields(llm), skills=directory_digest(library_dir), code=code_version()
        )
        results = ResultsFile(out, config)
    except (ConfigMismatchError, LLMError) as exc:
        fail(str(exc))
    done = results.done(Job.key_of)
    # by mode and trial: the prompts of one trial's order share their examples, which llama.cpp reuses
    todo = sorted((t for t in trials if t.key not in done), key=lambda t: (t.method, t.seed))
    run = condition_trial_runner(lambda: _generator(llm, 1, False), lambda: library)
    bar = tqdm(total=len(trials), desc=spec.name, unit="condition", file=sys.stderr, disable=None)
    bar.update(len(trials) - len(todo))
    crashed = []
    for trial in todo:
        try:
            results.append(run(trial))
        except Exception as exc:
            rec = trial.to_dict() | {"crashed": True}
            crashed.append(results.append(rec | {"error": f"{type(exc).__name__}: {exc}"[:300]}))
        bar.update()
    bar.close()
    _crashed(crashed)
    return results.results(), config.to_dict() | {"digest": config.digest, "crashed": len(crashed)}


@app.command()
def reproduce(
    table: Annotated[str, typer.Argument(help="table2, table3, table4 or all.")],
    out: Annotated[
        Path,
        typer.Option(
            "--out",
            help="Directory for tableN.md/.json/.png and the resumable results tableN.jsonl (a rerun with "
            "the same configuration resumes; another configuration is an error).",
        ),
    ],
    episodes: Annotated[
        int | None,
        typer.Option(
            "--episodes",
            min=1,
            help="Episodes (Table II: trials) per task and method; default per table: Table II 2 trials "
            "per primitive, Table III 2 episodes per primitive task (37 of them), Table IV 5 per "
            "long-horizon task.",
        ),
    ] = None,
    workers: WorkersOption = None,
    row: Annotated[
        list[str] | None,
        typer.Option(
            "--row", help="Only these rows (repeatable): a primitive id (grasp, ...) or LHT1..LHT2*."
        ),
    ] = None,
    column: Annotated[
        list[str] | None,
        typer.Option(
            "--column",
            help="Only these columns (repeatable): "
            + ", ".join(c.key for c in CONDITION_COLUMNS)
            + " (Table II); "
            + ", ".join(c.key for c in EXECUTION_COLUMNS)
            + f" (Tables III, IV); {GROUNDED_COLUMN.key} (Table IV). The others show as not run.",
        ),
    ] = None,
    backend: BackendOption = "local",
    ray_address: RayAddressOption = None,
    noise: NoiseOption = 0.005,
    llm: LlmOption = None,
    skills: SkillsOption = None,
    planner: PlannerOption = "none",
) -> None:
    """Run the paper's Tables II-IV with our numbers beside the paper's, Wilson 95% intervals, plots.
    The paper's protocol runs each sequence as given (``--planner none``, the default here)."""
    import time

    from taskcond.reproduce import only_columns, only_rows, table_specs, trials_for, write_table

    _sim_import()
    specs = table_specs()
    names = list(specs) if table == "all" else [table]
    if any(n not in specs for n in names):
        fail(f"table {table!r}: use one of {', '.join(specs)} or all")
    chosen = []
    for name in names:
        try:
            spec = only_rows(specs[name], row) if row else specs[name]
            chosen.append(only_columns(spec, column) if column else spec)
        except ValueError as exc:
            if len(names) == 1 or (name == names[-1] and not chosen):
                fail(str(exc))
            # else --row or --column names rows or columns of another table of "all"
    chosen = [_without_il(spec) for spec in chosen]
    settings = ExecutionSettings(workers, noise, llm, skills, backend, ray_address, planner)
    out.mkdir(parents=True, exist_ok=True)
    crashed = 0
    for spec in chosen:
        name = spec.name
        n = episodes or spec.default_episodes
        trials = trials_for(spec, n)
        start = time.perf_counter()
        if spec.kind == "conditions":
            records, config = _reproduce_conditions(spec, trials, out / f"{name}.jsonl", llm, skills)
        else:
            records, config = _run_episodes(trials, out / f"{name}.jsonl", settings, name)
            novel = trials_for(spec, n, novel_primitive=True)
            if novel:  # another configuration, so another results file
                more, novel_config = _run_episodes(
                    novel,
                    out / f"{name}-novel-primitive.jsonl",
                    replace(settings, novel_primitive=True),
                    f"{name} novel primitive",
                )
                records = records + more
                config["crashed"] += novel_config["crashed"]
                config["novel_primitive_digest"] = novel_config["digest"]
        seconds = time.perf_counter() - start
        crashed += config["crashed"]
        used = sum(not r.get("skipped") for r in records)
        footer = (
            f"{used} trials, {n} per task and method (seeds {spec.seed}+); this invocation "
            f"{seconds / 60:.1f} min; configuration {config['digest']} (code {config['code']}, LLM "
            f"{config['llm']}, noise {config['noise']})"
            + (
                f"; novel-primitive episodes: configuration {config['novel_primitive_digest']} "
                f"({name}-novel-primitive.jsonl)"
                if "novel_primitive_digest" in config
                else ""
            )
            + "; confidence intervals: Wilson score, 95%."
        )
        extra = {"episodes": n, "seconds": round(seconds, 1), "config": config}
        write_table(spec, records, n, out, extra, footer)
        typer.echo((out / f"{name}.md").read_text(encoding="utf-8"))
        typer.echo(f"wrote {out / name}.md, .json, .png", err=True)
    if crashed:
        raise typer.Exit(1)


def _without_il(spec):
    """``spec`` with the image-based baseline's column not run (and said why) when the [il] extra is
    missing."""
    from dataclasses import replace

    from taskcond.il import ILUnavailableError, require_il

    try:
        require_il()
    except ILUnavailableError as exc:
        blocks = tuple(
            replace(
                b,
                methods={k: m for k, m in b.methods.items() if m != "image-il"},
                pending={**b.pending, **{k: str(exc) for k, m in b.methods.items() if m == "image-il"}},
            )
            for b in spec.blocks
        )
        if blocks != spec.blocks:
            typer.echo(f"{spec.name}: the image-il column is not run: {exc}", err=True)
        return replace(spec, blocks=blocks)
    return spec


app.command(help="Run one stored episode of a results file again, to a Rerun recording or a video.")(
    cli_viz.replay
)


def main(args: list[str] | None = None) -> NoReturn:
    """The console entry point: :data:`app`, with click's usage errors (a missing argument, an option
    out of its range, an unknown option) as one ``error:`` line naming the help to read and exit code 2,
    like every other bad input, instead of click's framed message."""
    try:  # typer >= 0.22 carries its own copy of click
        from typer._click import exceptions as click
    except ImportError:
        from click import exceptions as click

    command = typer.main.get_command(app)
    try:
        code = command.main(args=args, prog_name="taskcond", standalone_mode=False)
    except click.NoArgsIsHelpError as exc:
        exc.show()
        raise SystemExit(2) from None
    except click.UsageError as exc:
        where = f"; see '{exc.ctx.command_path} --help'" if exc.ctx is not None else ""
        message = " ".join(exc.format_message().split()).rstrip(".")
        typer.echo(f"error: {message}{where}", err=True)
        raise SystemExit(2) from None
    except click.ClickException as exc:
        typer.echo(f"error: {' '.join(exc.format_message().split())}", err=True)
        raise SystemExit(exc.exit_code) from None
    except typer.Abort:
        typer.echo("aborted", err=True)
        raise SystemExit(130) from None
    raise SystemExit(code if isinstance(code, int) else 0)


if __name__ == "__main__":
    main()
