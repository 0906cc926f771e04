"""The machine a run used, as a results store's manifest records it (no host names).

Imports nothing heavy (a manifest is written by every run that stores trials).
"""

from __future__ import annotations

import os
import platform
from typing import Any

__all__ = ["describe_machine", "format_machine"]


def _cpu_model() -> str:
    """The CPU's model name (``/proc/cpuinfo``; else :func:`platform.processor`)."""
    try:
        with open("/proc/cpuinfo") as handle:
            for line in handle:
                if line.startswith("model name"):
                    return line.split(":", 1)[1].strip()
    except OSError:
        pass
    return platform.processor() or platform.machine()


def _memory_gib() -> float | None:
    """Physical memory in GiB (``None`` where the OS does not say)."""
    try:
        pages, size = os.sysconf("SC_PHYS_PAGES"), os.sysconf("SC_PAGE_SIZE")
    except (AttributeError, ValueError, OSError):  # pragma: no cover - non-POSIX
        return None
    return round(pages * size / 2**30, 1)


def describe_machine() -> dict[str, Any]:
    """CPU model, logical CPUs (those this process may use), memory, OS and Python."""
    cpus = len(os.sched_getaffinity(0)) if hasattr(os, "sched_getaffinity") else os.cpu_count()
    return {
        "cpu": _cpu_model(),
        "cpus": cpus,
        "memory_gib": _memory_gib(),
        "system": f"{platform.system()} {platform.release()} {platform.machine()}",
        "python": platform.python_version(),
    }


def format_machine(machine: dict[str, Any]) -> str:
    """One line of :func:`describe_machine`'s dict."""
    memory = machine.get("memory_gib")
    return (
        f"{machine.get('cpu', '?')}, {machine.get('cpus', '?')} logical CPU(s)"
        + (f", {memory:g} GiB" if memory is not None else "")
        + f", {machine.get('system', '?')}, Python {machine.get('python', '?')}"
    )
