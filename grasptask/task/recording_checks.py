"""What fit-task says of a recording that it fits all the same: uneven sampling, a recording too short to hold a
task, values no hand-held tool sees (a probable unit error), spikes, and a mean that dominates the spread.

Each check is a pure function of the samples that returns a :class:`Finding` (a line a person reads, and its
figures for ``task_models.json``) or None. The thresholds are constants here, chosen so that the simulator's
recordings and clean sensor noise raise none; the plausible range is the tool config's (``plausible``).
Statistics are robust (medians and median absolute deviations), on at most :data:`ROBUST_SAMPLE` evenly
spaced samples, so that a 10-million-sample log is checked in a fraction of its reading time.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np

#: robust statistics use at most this many evenly spaced samples
ROBUST_SAMPLE = 200_000
#: sampling is uneven where the 99th percentile of the intervals is over this many times the 1st
UNEVEN_RATIO = 2.0
#: a spike stands this many robust spreads (1.4826 MAD) off its channel's median ...
SPIKE_SPREADS = 8.0
#: ... and this many robust spreads off the samples on each side of it, both sides (a two-sided Hampel filter):
#: a step up or down is near the samples on one of its sides, a spike near neither
SPIKE_LOCAL = 20.0
#: ... which are this many on each side: a spike is at most half as long, a task's event is longer
SPIKE_SIDE = 40
#: spikes are rare: where more samples than this share stand out, the channel is heavy-tailed, not spiky
SPIKE_MAX_SHARE = 0.05
#: a channel's mean dominates where it is this many standard deviations off zero ...
OFFSET_RATIO = 10.0
#: ... and makes at least this share of its domain's (force or torque) second moment
OFFSET_SHARE = 0.25

CHANNELS = ("fx", "fy", "fz", "tx", "ty", "tz")
UNIT = {"fx": "N", "fy": "N", "fz": "N", "tx": "N.m", "ty": "N.m", "tz": "N.m"}


@dataclass(frozen=True)
class Finding:
    """One check's word on one recording: ``check`` names it, ``message`` says it with its figures and the fix,
    ``figures`` holds them for ``task_models.json``."""

    check: str
    message: str
    figures: dict[str, Any] = field(default_factory=dict)


def _every(values: np.ndarray) -> np.ndarray:
    """At most :data:`ROBUST_SAMPLE` of ``values``, evenly spaced."""
    step = max(1, len(values) // ROBUST_SAMPLE)
    return values[::step]


def _robust_spread(values: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Per column: the median and 1.4826 x the median absolute deviation (the SD, for Gaussian noise)."""
    sample = _every(values)
    centre = np.median(sample, axis=0)
    return centre, 1.4826 * np.median(np.abs(sample - centre), axis=0)


def uneven_sampling(t: np.ndarray, resample_hz: float | None, lowpass_hz: float | None) -> Finding | None:
    """Intervals that vary by over :data:`UNEVEN_RATIO` between their 1st and 99th percentiles: every sample
    weighs the same in the ellipsoid, so a slow stretch counts for less than its time."""
    steps = np.diff(t)
    low, median, high = np.percentile(_every(steps), [1, 50, 99])
    if high <= UNEVEN_RATIO * low:
        return None
    figures = {
        "interval_p1_s": float(low),
        "interval_median_s": float(median),
        "interval_p99_s": float(high),
        "interval_min_s": float(steps.min()),
        "interval_max_s": float(steps.max()),
    }
    if resample_hz:
        fix = f"resampled to {resample_hz:g} Hz as asked"
    else:
        fix = f"--resample {1.0 / median:.3g} (Hz, the median rate) puts the samples on an even grid"
        if lowpass_hz:
            fix += f"; --lowpass {lowpass_hz:g} assumes even sampling and is off where it is not"
    return Finding(
        "uneven sampling",
        f"uneven sampling: intervals {_ms(steps.min(), steps.max())} (1st-99th percentile {_ms(low, high)}, "
        f"median {_ms(median)}): each sample weighs the same, whatever time it stands for; {fix}",
        figures,
    )


def _ms(*seconds: float) -> str:
    """``18.8-153 ms``: one time, or a range, in milliseconds."""
    return "-".join(f"{s * 1e3:.3g}" for s in seconds) + " ms"


def too_short(t: np.ndarray, min_duration_s: float) -> Finding | None:
    duration = float(t[-1] - t[0])
    if duration >= min_duration_s:
        return None
    return Finding(
        "short",
        f"short: {duration:.3g} s, under the {min_duration_s:g} s a task takes at least (tool config "
        "plausible.min_duration_s): a window cut too tight, or the wrong time_unit?",
        {"duration_s": duration, "min_duration_s": min_duration_s},
    )


def extremes(wrenches: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Each channel's smallest and largest value: a column at a time, faster than numpy's reduction along rows
    of a long ``(n, 6)`` array, and shared by the checks that look at every sample only where these say so."""
    columns = [wrenches[:, c] for c in range(wrenches.shape[1])]
    return np.array([x.min() for x in columns]), np.array([x.max() for x in columns])


def spike_rows(wrenches: np.ndarray, bounds: tuple[np.ndarray, np.ndarray] | None = None) -> np.ndarray:
    """The samples (a boolean mask) that stand far off their channel's robust spread and off the samples on
    both sides of them, each side judged by its own median and spread: a sensor glitch, not a task. Computed
    only where the first test holds, and only on channels whose :func:`extremes` (``bounds``) reach past it."""
    n = len(wrenches)
    flagged = np.zeros(n, dtype=bool)
    if n < 2 * SPIKE_SIDE + 1:
        return flagged
    centre, spread = _robust_spread(wrenches)
    low, high = centre - SPIKE_SPREADS * spread, centre + SPIKE_SPREADS * spread
    smallest, largest = bounds if bounds is not None else extremes(wrenches)
    outside = (smallest < low) | (largest > high)  # a channel with nothing outside needs no look at its samples
    for c in np.flatnonzero(outside):
        x = wrenches[:, c]
        far = (x < low[c]) | (x > high[c])
        if far.mean() > SPIKE_MAX_SHARE:
            continue
        # a floor on the sides' spread: a quantised channel's neighbours can agree to the last bit
        floor = max(1e-3 * float(np.max(np.abs(x - centre[c]))), 1e-12)
        sides = np.lib.stride_tricks.sliding_window_view(np.pad(x, SPIKE_SIDE, mode="edge"), SPIKE_SIDE)
        at = np.flatnonzero(far)
        apart = np.ones(len(at), dtype=bool)
        for side in (sides[at], sides[at + SPIKE_SIDE + 1]):  # the samples before, and after
            middle = np.median(side, axis=1)
            scale = np.maximum(1.4826 * np.median(np.abs(side - middle[:, None]), axis=1), floor)
            apart &= np.abs(x[at] - middle) > SPIKE_LOCAL * scale
        flagged[at[apart]] = True
    return flagged


def spikes(wrenches: np.ndarray, flagged: np.ndarray, rows: np.ndarray, dropped: bool) -> Finding | None:
    """The spikes of :func:`spike_rows`, by their rows in the file (from 1) and their largest value."""
    if not flagged.any():
        return None
    where = np.flatnonzero(flagged)
    centre, _ = _robust_spread(wrenches)
    worst = np.abs(wrenches[where] - centre)
    row, c = np.unravel_index(int(np.argmax(worst)), worst.shape)
    name = CHANNELS[c]
    value = float(wrenches[where[row], c])
    shown = _rows(rows[where])
    fix = "left out, as asked (--drop-spikes)" if dropped else "kept; --drop-spikes leaves them out"
    return Finding(
        "spikes",
        f"spikes: {len(where)} samples far off the rest (rows {shown}), up to {name} = {value:.4g} "
        f"{UNIT[name]} where its median is {centre[c]:.3g}: {fix}",
        {"rows": [int(r) for r in rows[where][:100]], "count": int(len(where)), "channel": name, "value": value},
    )


def _rows(rows: np.ndarray) -> str:
    """``120-130, 4000``: row numbers as runs, the first few."""
    runs: list[str] = []
    start = previous = int(rows[0])
    for row in [*map(int, rows[1:]), None]:
        if row is not None and row == previous + 1:
            previous = row
            continue
        runs.append(f"{start}-{previous}" if previous > start else str(start))
        if row is not None:
            start = previous = row
    return ", ".join(runs[:5]) + (f" and {len(runs) - 5} more runs" if len(runs) > 5 else "")


def implausible(
    wrenches: np.ndarray, force_n: float, torque_nm: float, bounds: tuple[np.ndarray, np.ndarray] | None = None
) -> Finding | None:
    """A force or torque magnitude beyond the tool config's plausible range: the likeliest cause is a unit (a
    torque in N.mm read as N.m is 1,000 times too large), which the line names where one fits."""
    found = []
    figures: dict[str, Any] = {}
    smallest, largest_value = bounds if bounds is not None else extremes(wrenches)
    reach = np.maximum(-smallest, largest_value)
    for domain, block, bound, unit, key, channels in (
        ("force", wrenches[:, :3], force_n, "N", "force_unit", slice(0, 3)),
        ("torque", wrenches[:, 3:], torque_nm, "N.m", "torque_unit", slice(3, 6)),
    ):
        # the channels' extremes bound the magnitude from above: most recordings are judged by them alone
        if not len(block) or np.linalg.norm(reach[channels]) <= bound:
            continue
        largest = float(np.sqrt(np.einsum("ij,ij->i", block, block).max()))
        if largest <= bound:
            continue
        figures[f"{domain}_max"] = largest
        figures[f"{domain}_bound"] = bound
        guess = next((f for f in (1e3, 1e2) if largest / f <= bound), None)
        said = (
            f"; in {_smaller_unit(unit, guess)} it would be {largest / guess:.3g} {unit} ({key})"
            if guess is not None
            else ""
        )
        found.append(f"{domain} up to {largest:.4g} {unit}, beyond the {bound:g} {unit} of the tool config's "
                     f"plausible.{'force_n' if domain == 'force' else 'torque_nm'}{said}")  # fmt: skip
    if not found:
        return None
    return Finding("implausible", "implausible, probably a unit error: " + "; ".join(found), figures)


def _smaller_unit(unit: str, factor: float) -> str:
    return {("N", 1e3): "mN", ("N.m", 1e3): "N.mm", ("N.m", 1e2): "N.cm"}.get((unit, factor), f"1/{factor:g} {unit}")


def offset(mean: np.ndarray, moment: np.ndarray) -> Finding | None:
    """A channel whose mean is :data:`OFFSET_RATIO` standard deviations off zero and makes most of its domain's
    second moment: the ellipsoid is then the offset's (an untared sensor, or the tool's weight), not the task's.
    The default keeps it, as a task's steady push is a mean too. ``mean`` and ``moment`` are the channels' means
    and mean squares (the diagonal of the fitted second moment ``S``)."""
    sd = np.sqrt(np.clip(moment - mean**2, 0.0, None))
    said, figures = [], {}
    for c, name in enumerate(CHANNELS):
        domain = moment[:3] if c < 3 else moment[3:]
        share = float(mean[c] ** 2 / domain.sum()) if domain.sum() > 0 else 0.0
        if abs(mean[c]) > OFFSET_RATIO * sd[c] and share >= OFFSET_SHARE:
            said.append(
                f"{name} has a mean of {mean[c]:.3g} {UNIT[name]} against a spread (SD) of {sd[c]:.2g} {UNIT[name]} "
                f"({share:.0%} of the {'force' if c < 3 else 'torque'} ellipsoid's second moment)"
            )
            figures[name] = {"mean": float(mean[c]), "sd": float(sd[c]), "share": share}
    if not said:
        return None
    return Finding(
        "offset",
        "offset dominates: " + "; ".join(said) + ": an untared sensor or the tool's weight? --bias-window S "
        "subtracts a contact-free start, --centered fits the spread alone; the default keeps the mean, as a "
        "task's steady push is part of it",
        figures,
    )
