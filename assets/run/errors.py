"""How a run fails, in one line each: bad input relayed from a stage, a stage that raised, an interrupted run,
a damaged Dagster home, a failed shot of a batch."""
from __future__ import annotations

from pathlib import Path

from ops.errors import ShotError


class RelayedShotError(ShotError):
    """A ShotError raised inside a stage, relayed from its step with its one-line message unchanged."""

    def __init__(self, message: str):
        ValueError.__init__(self, message)
        self.file, self.field, self.problem, self.fix = "", "", message, ""


# what to try when a stage of this kind fails (the cause says what went wrong)
FIXES = {
    "masks": "check the keyframe image and its pose, or paint masks.foreground (see `inbetween masks`)",
    "refined_masks": "check this keyframe's T-junction clicks, or paint masks.occlusion",
    "template": "check that the key poses' joints lie on the drawing, or paint masks.foreground / masks.occlusion",
    "textured_template": "check the key poses' depths (z) and the occlusion masks",
    "deformed_frames": "check the in-between poses (a bone folding through itself, a joint far off the drawing)",
    "rife_matrix": "check INBETWEEN_DEVICE and the RIFE weights",
}
GENERIC_FIX = "rerun with --debug for the full trace, or see the log"


class StageFailed(RuntimeError):
    """A stage raised: one line naming the shot, the stage, the cause and a fix; the full trace is in the log."""

    def __init__(self, shot: str, stage: str, cause: str, log: Path | None, trace: str = "", fix: str | None = None):
        self.shot, self.stage, self.cause, self.log, self.trace = shot, stage, cause, log, trace
        cause = " ".join(cause.split())  # one line, whatever the exception's message held
        full = any(sign in cause for sign in DISK_FULL_SIGNS)
        fix = fix or (DISK_FULL_FIX if full else FIXES.get(stage.split("/")[-1], GENERIC_FIX))
        super().__init__(f"{shot}: {stage}: {cause}; fix: {fix}")


class RunInterrupted(StageFailed):
    """The run was stopped (Ctrl-C, SIGTERM from `timeout` or a scheduler) while a stage computed: not the stage's
    fault, so not its fix."""

    def __init__(self, shot: str, stage: str, log: Path | None, trace: str = ""):
        super().__init__(shot, stage, "interrupted (SIGINT or SIGTERM)", log, trace,
                         fix="rerun: the stages already stored are kept, and the run goes on from them")


INTERRUPTIONS = ("DagsterExecutionInterruptedError", "KeyboardInterrupt")  # how Dagster reports SIGINT / SIGTERM

DISK_FULL_FIX = "free disk space under INBETWEEN_HOME and the output folder, then rerun (stored stages are kept)"
DISK_FULL_SIGNS = ("No space left on device", "database or disk is full")  # OSError ENOSPC; SQLite's SQLITE_FULL


class HomeDamaged(RuntimeError):
    """The Dagster home cannot be opened (a damaged dagster.yaml or SQLite file): one line with its fix."""

    def __init__(self, path: Path, cause: BaseException):
        self.path = path
        text = " ".join(str(cause).split())[:200]
        super().__init__(f"{path}: the Dagster instance cannot be opened ({type(cause).__name__}: {text}); "
                         f"fix: remove {path} (stage outputs stay in INBETWEEN_HOME/storage; only the UI's "
                         f"run history is lost) and rerun")


class ShotFailure(str):
    """One failed shot of a batch: its one-line message (a str, as batch() always returned) plus the shot's
    name and whether its input was bad (exit 2) or a stage failed (exit 1)."""

    shot: str
    bad_input: bool

    def __new__(cls, message: str, shot: str, bad_input: bool):
        self = super().__new__(cls, message)
        self.shot, self.bad_input = shot, bad_input
        return self

    def __reduce__(self):  # crosses the process pool's pipe
        return ShotFailure, (str(self), self.shot, self.bad_input)


def raise_failure(events, shot: str, log_path: Path):
    """The one-line error of a failed run: a ShotError raised inside a stage as it was, else StageFailed."""
    failures = [e for e in events if e.event_type_value == "STEP_FAILURE"]
    if failures:
        ev = failures[0]
        err = ev.event_specific_data.error
        stage = ev.step_key.replace("__", "/")
        chain = [err]
        while chain[-1].cause is not None:
            chain.append(chain[-1].cause)
        for e in chain:  # bad input found inside a stage: the same one-line error as at loading
            if e.cls_name == "ShotError":
                text = e.message.strip().splitlines()[-1]
                raise RelayedShotError(text.split("ShotError: ", 1)[-1])
        if any(e.cls_name in INTERRUPTIONS for e in chain):
            raise RunInterrupted(shot, stage, log_path, err.to_string())
        cause = chain[-1]
        lines = cause.message.strip().splitlines()
        text = lines[0] if lines else "failed"
        raise StageFailed(shot, stage, text if text.startswith(cause.cls_name) else f"{cause.cls_name}: {text}",
                          log_path, err.to_string())
    cause = _run_failure_cause(events)
    if cause.split(":", 1)[0] in INTERRUPTIONS:
        raise RunInterrupted(shot, "run", log_path)
    raise StageFailed(shot, "run", cause, log_path)


def _run_failure_cause(events) -> str:
    """The first error a failed run reports outside any step (a resource that did not start, the engine)."""
    for ev in events:
        err = getattr(ev.event_specific_data, "error", None)
        if err is not None:
            while err.cause is not None:
                err = err.cause
            lines = err.message.strip().splitlines()
            return f"{err.cls_name}: {lines[0] if lines else 'failed'}"
    return "the Dagster run failed"
