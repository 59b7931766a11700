"""Optional preprocessing of wrench samples: resampling to an even rate, bias removal, trimming, zero-phase
low-pass filtering."""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from grasptask.errors import BadInputError


@dataclass(frozen=True)
class Preprocess:
    """Preprocessing options; all off by default.

    ``bias_window_s`` overrides each recording's own static window from the manifest when given;
    ``resample_hz`` puts unevenly sampled recordings on an even grid first; ``drop_spikes`` leaves out the samples
    :func:`grasptask.task.recording_checks.spike_rows` finds.
    """

    bias_window_s: float | None = None
    trim_start_s: float = 0.0
    trim_end_s: float = 0.0
    lowpass_hz: float | None = None
    lowpass_order: int = 4
    resample_hz: float | None = None
    drop_spikes: bool = False

    def __post_init__(self) -> None:
        if self.resample_hz is not None and not 0 < self.resample_hz <= MAX_RESAMPLE_HZ:
            raise BadInputError(
                "--resample", f"{self.resample_hz:g} Hz is beyond {MAX_RESAMPLE_HZ:g} Hz (force/torque sensors "
                "sample at a few kHz)",
            )  # fmt: skip


#: the highest rate a recording is resampled to (Hz): F/T sensors sample at up to a few kHz (an ATI Net F/T
#: at 7 kHz); 1e9 Hz asked for 68 GiB
MAX_RESAMPLE_HZ = 100_000.0
#: the most samples one recording is resampled to: 20 million (1.1 GB of wrenches), an hour at 5.5 kHz
MAX_RESAMPLED = 20_000_000


def resample(t: np.ndarray, wrenches: np.ndarray, rate_hz: float) -> tuple[np.ndarray, np.ndarray]:
    """The samples linearly interpolated onto an even grid at ``rate_hz`` from the first sample's time, so that
    each sample stands for the same time in the ellipsoid's mean."""
    count = float(np.floor((t[-1] - t[0]) * rate_hz + 1e-9)) + 1
    if count > MAX_RESAMPLED:
        raise ValueError(
            f"resampling {t[-1] - t[0]:.6g} s at {rate_hz:g} Hz makes {count:.3g} samples, beyond {MAX_RESAMPLED:.3g}"
        )
    grid = t[0] + np.arange(int(count)) / rate_hz
    return grid, np.column_stack([np.interp(grid, t, wrenches[:, c]) for c in range(wrenches.shape[1])])


def remove_bias(t: np.ndarray, wrenches: np.ndarray, window_s: float) -> tuple[np.ndarray, np.ndarray]:
    """Subtract the mean of the initial static window (sensor offset plus end-effector weight), then drop it."""
    static = t < t[0] + window_s
    if not static.any() or static.all():
        raise ValueError(f"bias window of {window_s} s leaves no static or no task samples")
    return t[~static], wrenches[~static] - wrenches[static].mean(axis=0)


def trim(t: np.ndarray, wrenches: np.ndarray, start_s: float, end_s: float) -> tuple[np.ndarray, np.ndarray]:
    keep = (t >= t[0] + start_s) & (t <= t[-1] - end_s)
    return t[keep], wrenches[keep]


def lowpass(t: np.ndarray, wrenches: np.ndarray, cutoff_hz: float, order: int = 4) -> np.ndarray:
    """Zero-phase Butterworth low-pass at ``cutoff_hz``, sampling rate from the median time step."""
    rate = 1.0 / float(np.median(np.diff(t)))
    if cutoff_hz >= rate / 2:
        raise ValueError(f"low-pass cutoff {cutoff_hz} Hz is not below the Nyquist rate {rate / 2:.1f} Hz")
    from scipy import signal  # deferred: scipy.signal takes a second to import, and only fit-task filters

    sos = signal.butter(order, cutoff_hz, fs=rate, output="sos")
    padlen = min(len(t) - 1, 3 * (2 * len(sos) + 1))
    return signal.sosfiltfilt(sos, wrenches, axis=0, padlen=padlen)


def apply(
    t: np.ndarray, wrenches: np.ndarray, options: Preprocess, bias_window_s: float = 0.0
) -> tuple[np.ndarray, np.ndarray]:
    """Resampling, bias removal (recording's window unless overridden), trimming, then filtering."""
    if options.resample_hz:
        t, wrenches = resample(t, wrenches, options.resample_hz)
    window = options.bias_window_s if options.bias_window_s is not None else bias_window_s
    if window > 0:
        t, wrenches = remove_bias(t, wrenches, window)
    if options.trim_start_s or options.trim_end_s:
        t, wrenches = trim(t, wrenches, options.trim_start_s, options.trim_end_s)
    if options.lowpass_hz:
        wrenches = lowpass(t, wrenches, options.lowpass_hz, options.lowpass_order)
    return t, wrenches
