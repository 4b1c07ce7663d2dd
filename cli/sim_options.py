"""Simulation options shared by `simulate`, `simplify` and `compare`.

`simulation_options` is a decorator bundle (as sqlite-utils does it), and
`SimulationSettings.from_options` turns the parsed values into a wind object,
Δt and a step count, with one set of checks for every command.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import click

from .io import read_text


def _vector(text: str) -> tuple[float, float, float]:
    parts = text.split(",")
    if len(parts) != 3:
        raise click.BadParameter("expected three numbers VX,VY,VZ")
    try:
        out = tuple(float(p) for p in parts)
    except ValueError:
        raise click.BadParameter("expected three numbers VX,VY,VZ") from None
    if not all(math.isfinite(v) for v in out):
        raise click.BadParameter("components must be finite")
    return out  # type: ignore[return-value]


def _wind_vector(ctx, param, value):
    """Callback of --wind: "VX,VY,VZ" -> a tuple of three finite floats (or None)."""
    return None if value is None else _vector(value)


def _finite(ctx, param, value):
    if value is not None and not math.isfinite(value):
        raise click.BadParameter("must be a finite number")
    return value


def simulation_options(func=None, *, dt_required: bool = True):
    """Add --dt, --duration/--steps, wind, gust and damping options to a command.

    Use bare (``@simulation_options``) or as ``@simulation_options(dt_required=False)``
    for a command that checks itself whether it needs --dt (compare on CSVs alone).
    """
    if func is None:
        return lambda f: simulation_options(f, dt_required=dt_required)
    options = [
        click.option("--dt", type=click.FloatRange(min=0, min_open=True), required=dt_required,
                     callback=_finite, help="Time step Δt in seconds."),
        click.option("--duration", type=click.FloatRange(min=0), default=None, callback=_finite,
                     help="Simulated time in seconds (steps = round(T / Δt))."),
        click.option("--steps", type=click.IntRange(min=0), default=None,
                     help="Number of time steps (instead of --duration)."),
        click.option("--wind", "wind_vector", metavar="VX,VY,VZ", default=None,
                     callback=_wind_vector, help="Constant wind vector in m/s (world frame, z up)."),
        click.option("--wind-speed", type=click.FloatRange(min=0), default=None,
                     callback=_finite, help="Constant wind speed in m/s ..."),
        click.option("--wind-direction", type=float, default=None, callback=_finite,
                     help="... blowing toward this azimuth in degrees (0 = +x, 90 = +y; "
                          "default 0)."),
        click.option("--wind-file", type=str, default=None, metavar="KEYS.csv",
                     help="Wind over time: rows t,vx,vy,vz, linearly interpolated, "
                          "held beyond the ends."),
        click.option("--gust-strength", type=click.FloatRange(min=0), default=0.0,
                     show_default=True, callback=_finite,
                     help="Add seeded gusts of this relative strength (0: none; see docs/model.md)."),
        click.option("--gust-seed", type=click.IntRange(min=0), default=0, show_default=True,
                     help="Seed of the gust model."),
        click.option("--damping", type=click.FloatRange(min=0, max=2, max_open=True),
                     default=0.0, show_default=True, callback=_finite,
                     help="Velocity damping c (0 = the thesis' undamped model)."),
        click.option("--damping-ratio", type=click.FloatRange(min=0), default=None,
                     callback=_finite,
                     help="Damping ratio ζ of every branch, by its own period (measured trees: "
                          "0.02-0.10); instead of --damping."),
    ]
    for option in reversed(options):
        func = option(func)
    return func


@dataclass
class SimulationSettings:
    """Parsed simulation options: Δt (s), number of steps, the wind, the damping (c or ζ,
    a `plantlod.sim.damping.Damping`)."""

    dt: float
    steps: int
    wind: object
    damping: object
    description: str

    @classmethod
    def from_options(cls, dt, duration, steps, wind_vector, wind_speed, wind_direction,
                     wind_file, gust_strength, gust_seed, damping,
                     damping_ratio=None) -> "SimulationSettings":
        if (duration is None) == (steps is None):
            raise click.UsageError("give exactly one of --duration and --steps")
        from plantlod.sim.constants import MAX_TIME_STEPS, MIN_TIME_STEP

        if dt is not None and dt < MIN_TIME_STEP:
            raise click.BadParameter(f"{dt:g} s is below the smallest time step, "
                                     f"{MIN_TIME_STEP:g} s", param_hint="--dt")
        if steps is None:
            count = duration / dt
            if not count <= MAX_TIME_STEPS:
                raise click.UsageError(f"--duration {duration:g} / --dt {dt:g} gives more than "
                                       f"{MAX_TIME_STEPS:,} steps, the limit of one run")
            steps = int(round(count))
            from plantlod.sim.run import refuse_no_step

            refuse_no_step(steps, dt, duration, "--dt", "--duration")
        elif steps > MAX_TIME_STEPS:
            raise click.BadParameter(f"{steps:,} is more than {MAX_TIME_STEPS:,} steps, the limit "
                                     "of one run", param_hint="--steps")
        from plantlod.sim.wind import ConstantWind, GustyWind, KeyframeWind, wind_from_speed

        given = [w for w in (wind_vector, wind_speed, wind_file) if w is not None]
        if len(given) > 1:
            raise click.UsageError("give at most one of --wind, --wind-speed and --wind-file")
        if wind_direction is not None and wind_speed is None:
            raise click.UsageError("--wind-direction applies to --wind-speed; give a speed too "
                                   "(or the whole vector with --wind VX,VY,VZ)")
        if gust_seed and not gust_strength:
            raise click.UsageError("--gust-seed applies to gusts; give --gust-strength G > 0 too")
        wind_direction = 0.0 if wind_direction is None else wind_direction
        if wind_file is not None:
            import io

            text = read_text(wind_file, expected="a wind CSV (rows t,vx,vy,vz)")
            wind = KeyframeWind.from_csv(io.StringIO(text), "<stdin>" if wind_file == "-" else wind_file)
            description = f"wind file {wind_file}"
        elif wind_speed is not None:
            wind = wind_from_speed(wind_speed, wind_direction)
            description = f"wind {wind_speed:g} m/s toward {wind_direction:g} deg"
        else:
            if wind_vector is None:
                vector = (0.0, 0.0, 0.0)
            elif isinstance(wind_vector, str):
                vector = _vector(wind_vector)
            else:
                vector = tuple(wind_vector)
            wind = ConstantWind(vector)
            description = "wind ({:g}, {:g}, {:g}) m/s".format(*vector)
        keys = wind.vectors if isinstance(wind, KeyframeWind) else wind.sample([0.0])
        if not keys.any():
            from .io import warn_once_running
            warn_once_running("the wind is zero, so the tree stays at rest; give --wind-speed S, "
                 "--wind VX,VY,VZ or --wind-file")
        if gust_strength > 0:
            wind = GustyWind(wind, seed=gust_seed, strength=gust_strength)
            description += f", gusts {gust_strength:g} (seed {gust_seed})"
        from plantlod.sim.damping import as_damping

        if damping_ratio is not None and damping:
            raise click.UsageError("give either --damping c or --damping-ratio ζ, not both")
        damped = as_damping(damping, damping_ratio)
        if damped.ratio:
            description += f", damping ratio {damped.ratio:g}"
        return cls(dt=dt, steps=steps, wind=wind, damping=damped, description=description)


# the keyword arguments `simulation_options` adds to a command
SIMULATION_PARAMS = ("dt", "duration", "steps", "wind_vector", "wind_speed", "wind_direction",
                     "wind_file", "gust_strength", "gust_seed", "damping", "damping_ratio")


def settings_from_kwargs(kwargs: dict) -> SimulationSettings:
    """Pop the simulation options out of a command's keyword arguments."""
    return SimulationSettings.from_options(**{n: kwargs.pop(n) for n in SIMULATION_PARAMS})
