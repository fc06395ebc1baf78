"""What each command's ``--help`` lists: models, presets, laws and the keys of its file.

Everything is read from the registries and file models themselves (`MODELS`, the preset
folder, `LAWS`, the pydantic models of the files), when the help is shown.
"""

from __future__ import annotations

import typing

from pydantic import BaseModel


def _model_of(annotation) -> type[BaseModel] | None:
    """The pydantic model a field holds (directly, in a list, or optionally)."""
    if isinstance(annotation, type) and issubclass(annotation, BaseModel):
        return annotation
    for arg in typing.get_args(annotation):
        if found := _model_of(arg):
            return found
    return None


def file_keys(model: type[BaseModel]) -> str:
    """The tables of a file model and their keys, one table a paragraph."""
    lines, top = [], []
    for name, field in model.model_fields.items():
        table = _model_of(field.annotation)
        if table is None:
            top.append(name)
            continue
        brackets = f"[[{name}]]" if typing.get_origin(field.annotation) is list else f"[{name}]"
        lines.append(f"{brackets} {', '.join(table.model_fields)}")
    return "\n\n".join(([f"top level: {', '.join(top)}"] if top else []) + lines)


def _presets() -> str:
    from trackdyn.vehicle.parameters import PRESETS

    names = (p.name.removesuffix(".toml") for p in PRESETS.iterdir() if p.name.endswith(".toml"))
    return ", ".join(sorted(names))


def choices(command: str) -> str:
    """The help epilogue of ``command``: paragraphs separated by blank lines."""
    from trackdyn.vehicle.models import MODELS

    vehicles = f"Models: {', '.join(MODELS)}.\n\nVehicle presets: {_presets()}."
    if command == "run":
        from trackdyn.commands.run import Scenario

        return f"{vehicles}\n\nScenario keys:\n\n{file_keys(Scenario)}"
    if command == "study":
        from trackdyn.studies.scenarios import Study

        return f"{vehicles}\n\nStudy keys:\n\n{file_keys(Study)}"
    if command in ("deteriorate", "calibrate"):
        from trackdyn.commands.deteriorate.scenario import DeteriorationScenario
        from trackdyn.deterioration.settlement import LAWS

        spec: type[DeteriorationScenario] = DeteriorationScenario
        if command == "calibrate":
            from trackdyn.commands.calibrate.spec import CalibrationScenario

            spec = CalibrationScenario
        laws = f"Settlement laws: {', '.join(LAWS)}."
        return f"{vehicles}\n\n{laws}\n\n{command.capitalize()} file keys:\n\n{file_keys(spec)}"
    if command == "track":
        from trackdyn.track.rails import RAIL_SECTIONS

        return f"Rail sections: {', '.join(RAIL_SECTIONS)}."
    return ""
