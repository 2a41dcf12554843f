"""Parametric models, as ``truss-deploy generate KIND`` writes them.

Each function takes the command's options as keyword arguments (the long
option without ``--``, ``_`` for ``-``: ``mu``, ``tension_n``, ``start_deg``)
and returns a :class:`truss_deploy.Model`. An option left at ``None`` takes
the command's default, and the command's checks apply (a bad value raises
ValueError with its message). The same names are a sweep's ``[base.args]``.
"""

from typing import Optional, Sequence, Union

from ._native import Model, _generate

__all__ = ["mast", "ring", "sail", "model"]


def _arg(name: str, value: object):
    if isinstance(value, bool):
        return (name, None) if value else None
    if isinstance(value, (int, float)):
        return (name, repr(value) if isinstance(value, float) else str(value))
    if isinstance(value, str):
        return (name, value)
    raise TypeError(f"generate option `{name}`: give a number, a str or a bool, not {type(value).__name__}")


def model(kind: str, **options: Union[int, float, str, bool, None]) -> Model:
    """``truss-deploy generate KIND --OPTION=VALUE ...``: ``kind`` is "mast",
    "ring" or "sail"; ``True`` gives a flag (``bay_by_bay=True``), ``None``
    or ``False`` leaves an option out."""
    if kind not in ("mast", "ring", "sail"):
        raise ValueError(f"generate: no kind `{kind}`; give mast, ring or sail")
    args = []
    for name, value in options.items():
        if value is None:
            continue
        a = _arg(name, value)
        if a is not None:
            args.append(a)
    return _generate(kind, args)


def mast(
    *,
    units: Optional[int] = None,
    rod_length_m: Optional[float] = None,
    joint_mass_kg: Optional[float] = None,
    tension_n: Optional[float] = None,
    mu: Optional[float] = None,
    damping: Optional[float] = None,
    start_deg: Optional[float] = None,
    deploy_deg: Optional[float] = None,
    latch_stiffness: Optional[float] = None,
    latch_damping: Optional[float] = None,
) -> Model:
    """Pantograph mast (``generate mast``).

    units: scissor units (1 to 500; default 4). rod_length_m: rod length (m;
    0.5). joint_mass_kg: lumped mass per joint (kg; 0.15). tension_n: the
    drive's constant motor tension (N; 0.02). mu: pulley friction (0.005).
    damping: viscous damping per joint (N s/m; 0). start_deg, deploy_deg: rod
    angle from the horizontal at the start and where the sleeves latch (deg;
    5, 60). latch_stiffness, latch_damping: compliant latches (N/m, N s/m);
    rigid without them.
    """
    return model("mast", **{k: v for k, v in locals().items()})


def ring(
    *,
    sides: Optional[int] = None,
    sync: Union[bool, str, None] = None,
    stow: bool = False,
    bay_by_bay: bool = False,
    mount: Optional[str] = None,
    tension_n: Optional[float] = None,
    mu: Optional[float] = None,
    damping: Optional[float] = None,
    start_deg: Optional[float] = None,
    latch_stiffness: Optional[float] = None,
    latch_damping: Optional[float] = None,
    gear_stiffness: Optional[float] = None,
    gear_damping: Optional[float] = None,
    stroke_stops: Optional[float] = None,
    stroke_stop_damping: Optional[float] = None,
    inner_chord_m: Optional[float] = None,
    members: Optional[str] = None,
    bus_mass_kg: Optional[float] = None,
    bus_inertia: Optional[Sequence[float]] = None,
    bus_offset_m: Optional[float] = None,
) -> Model:
    """Double-ring truss (``generate ring``; the bay-by-bay ring by default).

    sides: 6 to 360 (default 18). sync: the synchronized ring (True, or its
    gears: "both", "axial", "radial", "none"). stow: the one-mechanism
    stowing ring. bay_by_bay: the bay-by-bay ring (the default). mount:
    "hub", "frame0", "post" or "bus" (a free-floating spacecraft bus:
    bus_mass_kg, bus_inertia (Ixx, Iyy, Izz, kg m^2), bus_offset_m (m);
    docs/bus.md). tension_n: drive tension (N). mu: pulley
    friction. damping: per joint (N s/m). start_deg: tilt of the outer bays'
    chords at the start (deg, 0 = deployed). latch_stiffness, latch_damping:
    compliant latches (N/m, N s/m). gear_stiffness, gear_damping: the
    bay-by-bay ring's gears (N/m, N s/m). stroke_stops, stroke_stop_damping:
    end stops at the sleeves' stroke ends (N/m, N s/m; 0 for none).
    inner_chord_m: inner chord (m). members: "elastic" or "rigid".
    """
    options = dict(locals())
    if bus_inertia is not None:
        options["bus_inertia"] = ",".join(repr(float(v)) for v in bus_inertia)
    return model("ring", **options)


def sail(
    *,
    bays: Optional[int] = None,
    tension_n: Optional[float] = None,
    mu: Optional[float] = None,
    damping: Optional[float] = None,
    start_deg: Optional[float] = None,
    deploy_deg: Optional[float] = None,
) -> Model:
    """Sail (solar) array (``generate sail``).

    bays: 1 to 100 (default 4). tension_n: each cable's tension (N; 10). mu:
    pulley friction. damping: per joint (N s/m). start_deg, deploy_deg: rod
    angle from the vertical at the start and where the sleeves latch (deg;
    1, 55).
    """
    return model("sail", **{k: v for k, v in locals().items()})
