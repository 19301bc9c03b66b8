"""What differs between the options of a results folder and those of a new run (the ``--resume`` refusal)."""

from __future__ import annotations

import dataclasses

__all__ = ["option_changes"]


def option_changes(info: dict, task) -> str:
    """What differs between the task and options stored in a results folder (its manifest ``info``) and ``task``.

    Returns ``"gaps: refuse -> restart, interval: 100.0 -> 50.0"`` (sorted by option name, only the options that
    differ), or ``"task: iri -> reconstruct"``. An option the manifest does not hold (``gaps`` and ``min_valid`` are
    stored only with ``gaps="restart"``) is compared at its default.
    """
    if info.get("task") != task.name:
        return f"task: {info.get('task')} -> {task.name}"
    fields = dataclasses.fields(task) if dataclasses.is_dataclass(task) else ()
    defaults = {f.name: f.default for f in fields if f.default is not dataclasses.MISSING}
    old, new = info.get("options") or {}, task.options()

    def value(options, k):
        return options.get(k, defaults.get(k))

    changed = [f"{k}: {value(old, k)} -> {value(new, k)}" for k in sorted({*old, *new})
               if value(old, k) != value(new, k)]
    return ", ".join(changed) or "the same values, stored by another version of longprofile"
