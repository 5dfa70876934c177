"""Law artefacts as contenders of a comparison (``rig compare --policy FILE``).

Any file of the one law format (:mod:`controllers.laws.artefact`: a trained policy ``rig train`` wrote, a
law ``rig-deploy export`` wrote, a shipped ``controllers/policies/*.json``) flies the task its loop spec
names, beside the registered laws, and is named after its file (``runs/x/bank_ppo.json`` is
``bank_ppo``) in every table and in ``summary.json``.  A file is flown as it is: its numpy runtime
(``Artefact.controller``), never redesigned.  It must have been made for the task's loop as the
comparison flies it (free joints, observation and action layout, control period, task options; the
airspeed range may differ); otherwise it is skipped with the field that differs.
"""

from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path
from typing import Sequence

from controllers.laws.artefact import Artefact, ArtefactError, load
from controllers.laws.base import Controller, LoopSpec, UnsupportedTask

SPEC_FIELDS = ("task", "free_dofs", "obs_labels", "action_names", "dt", "action_scale_deg", "task_options")
"""The loop-spec fields an artefact must share with the task it flies (not ``airspeed_range``)."""


@dataclass(frozen=True)
class Contender:
    """A law artefact in a comparison: its name (the file's stem), path, and the loaded file."""

    name: str
    path: str
    artefact: Artefact

    @property
    def task(self) -> str:
        return self.artefact.spec.task

    def describe(self) -> dict[str, str]:
        return {"path": self.path, "sha256": self.artefact.sha256, "kind": self.artefact.kind, "task": self.task}

    def check(self, spec: LoopSpec) -> None:
        """UnsupportedTask naming the first loop-spec field in which this artefact differs from ``spec``."""
        for f in SPEC_FIELDS:
            mine, theirs = getattr(self.artefact.spec, f), getattr(spec, f)
            if (dict(mine) if f == "task_options" else mine) != (dict(theirs) if f == "task_options" else theirs):
                raise UnsupportedTask(f"{self.path} was made for {f} = {mine!r}; this comparison flies {f} = {theirs!r}")

    def build(self, spec: LoopSpec, num_envs: int) -> Controller:
        """The file's runtime for ``num_envs`` environments of the loop ``spec`` (checked first)."""
        self.check(spec)
        return self.artefact.controller(num_envs)


def load_contenders(paths: Sequence[str | Path], kinds: Sequence[str]) -> list[Contender]:
    """Load every file (an ArtefactError, a ValueError, names a bad one); names must be distinct and not a law kind."""
    out: list[Contender] = []
    for p in paths:
        path = Path(p)
        name = path.stem
        if name in kinds:
            raise ValueError(f"--policy {path}: its name {name!r} is a law kind of this comparison; rename the file")
        if any(c.name == name for c in out):
            raise ValueError(f"--policy {path}: a second file named {name!r}; every contender is named after its file, rename one")
        try:
            artefact = load(path)
        except ArtefactError as exc:  # its message names the file; the option it came from is said here
            raise ArtefactError(f"--policy {exc}") from None
        out.append(Contender(name, str(path), artefact))
    return out
