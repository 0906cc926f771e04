"""Portable labels of trained-policy groups in a results store.

A benchmark group of a trained policy (``infoseek bench --policy PATH``) is keyed by a label
that names the model file wherever the store and the checkout lie, so a store resumes and
verifies from any copy of the repository:

* ``policy:shipped/<name>`` -- a model installed with infoseek
  (``infoseek/baselines/models/<name>/model.zip``, :func:`infoseek.baselines.shipped_model`);
* ``policy:<relative path>`` -- any other model, by its path relative to the store directory
  (POSIX separators, e.g. ``policy:../ppo_20_step_episodes/model.zip`` for a model next to
  the store);
* ``policy:/absolute/path`` -- stores written before these labels; still read and run, and
  ``infoseek migrate DIR`` rewrites them to the portable forms (:func:`portable_label`).

Readable names for tables (:func:`display_name`): ``policy <run directory>`` (the folder of a
``model.zip``), e.g. ``policy ppo_bearings_v0_4agents``.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path, PurePosixPath

__all__ = [
    "POLICY_PREFIX",
    "SHIPPED_PREFIX",
    "display_name",
    "is_policy",
    "policy_file",
    "portable_label",
    "shipped_models_dir",
]

POLICY_PREFIX = "policy:"
SHIPPED_PREFIX = "shipped/"
MODEL_FILE = "model.zip"


def shipped_models_dir() -> Path:
    """The folder of the models installed with infoseek (without importing torch)."""
    import infoseek.baselines

    return Path(infoseek.baselines.__file__).resolve().parent / "models"


def is_policy(label: str) -> bool:
    """Whether ``label`` names a trained policy."""
    return label.startswith(POLICY_PREFIX)


def portable_label(model: str | os.PathLike[str], store: str | os.PathLike[str]) -> str:
    """The label of the model file ``model`` in the store ``store`` (module docstring).

    Args:
        model: Path of the model (``model.zip`` or a checkpoint); must exist.
        store: The results directory (need not exist yet).
    """
    path = Path(model).expanduser().resolve()
    shipped = shipped_models_dir()
    if path.parent.parent == shipped and path.name == MODEL_FILE:
        return f"{POLICY_PREFIX}{SHIPPED_PREFIX}{path.parent.name}"
    root = Path(store).expanduser().resolve()
    try:
        relative = os.path.relpath(path, root)
    except ValueError:  # another drive (Windows): no relative path
        return POLICY_PREFIX + str(path)
    return POLICY_PREFIX + PurePosixPath(*Path(relative).parts).as_posix()


def policy_file(label: str, store: str | os.PathLike[str]) -> Path:
    """The model file a policy label names, for the store in ``store``.

    Raises:
        ValueError: ``label`` is not a policy label.
    """
    if not is_policy(label):
        raise ValueError(f"{label!r} is not a trained-policy label ({POLICY_PREFIX}...)")
    name = label[len(POLICY_PREFIX) :]
    if name.startswith(SHIPPED_PREFIX):
        return shipped_models_dir() / name[len(SHIPPED_PREFIX) :] / MODEL_FILE
    path = Path(name)
    if path.is_absolute():
        return path
    return Path(os.path.normpath(Path(store).expanduser().resolve() / path))


def display_name(label: str) -> str:
    """A short readable name of a planner label (policies: ``policy <run directory>``)."""
    if not is_policy(label):
        return label
    name = label[len(POLICY_PREFIX) :]
    if name.startswith(SHIPPED_PREFIX):
        return f"policy {name[len(SHIPPED_PREFIX) :]}"
    path = PurePosixPath(name.replace(os.sep, "/"))
    if path.name == MODEL_FILE and path.parent.name:
        return f"policy {path.parent.name}"
    return f"policy {path.parent.name}/{path.stem}" if path.parent.name else f"policy {path.stem}"


def migration(
    labels: list[str], store: str | os.PathLike[str], relocate: Mapping[str, str] | None = None
) -> dict[str, str]:
    """Old label -> portable label for every absolute-path policy label in ``labels``.

    Args:
        labels: The planner labels of a store.
        store: The store's directory.
        relocate: Path prefixes to replace before resolving (``{old checkout: new}``), for a
            store written in a checkout that no longer exists.

    Raises:
        ValueError: A model file that does not exist (the message says which and how to map it).
    """
    changes = {}
    for label in labels:
        if not is_policy(label) or not Path(label[len(POLICY_PREFIX) :]).is_absolute():
            continue
        path = label[len(POLICY_PREFIX) :]
        for old, new in (relocate or {}).items():
            if path.startswith(old.rstrip("/") + "/"):
                path = new.rstrip("/") + path[len(old.rstrip("/")) :]
        if not Path(path).is_file():
            raise ValueError(
                f"group {label!r}: no model file at {path}; map the old checkout to this one "
                "with --relocate OLD=NEW"
            )
        changes[label] = portable_label(path, store)
    return changes
