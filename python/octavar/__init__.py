"""octavar: MEMS gyroscope characterisation with the Allan variance (IEEE Std 952), on numpy arrays.

Three layers, one library underneath (the Rust crate `octavar`, through the extension module `octavar._octavar`):

- ``adev``, ``oadev``, ``mdev``, ``hdev``, ``ohdev``, ``tdev``, ``totdev``: allantools' signature and result,
  ``(taus, devs, errs, ns)``, with allantools' tau lists, so a script switches by changing its import;
- ``deviation``: one statistic as ``octavar analyze`` tabulates it, with the interval at a chosen confidence, the
  EDF and the noise type at each tau;
- ``fit`` and ``fit_deviations``: the IEEE 952 terms N, B, K, R, Q with intervals, as a dict; ``model_adev``
  draws the fitted curve; ``gap``: the sim-to-real gap diagnosis, as the dict of ``octavar gap --json``;
  ``read``: samples and rate from every format ``octavar analyze`` reads; ``simulate``: the virtual bench.

Input arrays are read in place when they are contiguous float64 (any other array is converted once), and the GIL
is released while octavar computes. A NaN sample is an error unless ``gaps=True``, where it marks a missing
sample, as an empty cell does for ``octavar analyze``. Bad input raises ``ValueError``, an unreadable file
``OSError``, each with the message the ``octavar`` command prints.
"""

import os

import numpy as np

from . import _octavar

__all__ = [
    "adev",
    "oadev",
    "mdev",
    "hdev",
    "ohdev",
    "tdev",
    "totdev",
    "deviation",
    "fit",
    "fit_deviations",
    "model_adev",
    "gap",
    "read",
    "simulate",
]

try:
    from importlib.metadata import version as _version

    __version__ = _version("octavar")
except Exception:  # pragma: no cover - an uninstalled checkout
    __version__ = "0+unknown"


def _samples(data, name="data"):
    """``data`` as a contiguous 1-D float64 array: the array itself where it is one, else one converted copy."""
    a = np.asarray(data)
    if a.dtype.kind not in "fiu":
        raise ValueError(f"{name}: dtype {a.dtype} is not a real number type; give float or integer samples")
    if a.ndim != 1:
        raise ValueError(f"{name} must be one-dimensional; its shape is {a.shape}")
    if a.size == 0:
        raise ValueError(f"{name} is empty")
    return np.ascontiguousarray(a, dtype=np.float64)


def _optional(data, name):
    return None if data is None else _samples(data, name)


def _tau_request(taus, n_phase, rate):
    """allantools' ``taus`` argument for the extension: a name, or taus in seconds."""
    if taus is None:
        return "octave"
    if isinstance(taus, str):
        if taus == "log10":
            # As allantools' tau_generator: about 10 taus per decade over the phase points.
            maxn = np.log10(n_phase)
            return (1.0 / rate) * np.logspace(0, maxn, int(10 * maxn), base=10.0)
        return taus
    return _samples(np.asarray(taus, dtype=np.float64).ravel(), "taus")


def _allan(stat, data, rate, data_type, taus, gaps):
    data = _samples(data)
    n_phase = data.size + (1 if data_type == "freq" else 0)
    return _octavar.allan(stat, data, float(rate), data_type, _tau_request(taus, n_phase, float(rate)), bool(gaps))


def adev(data, rate=1.0, data_type="phase", taus=None, *, gaps=False):
    """Allan deviation (non-overlapping), as ``allantools.adev``: returns ``(taus, devs, errs, ns)``.

    ``data`` is phase (s) or, with ``data_type="freq"``, frequency or rate samples (a gyro's deg/s), ``rate``
    samples per second. ``taus`` is ``"octave"`` (the default), ``"decade"``, ``"all"``, ``"log10"`` or taus in
    seconds. ``errs`` is devs / sqrt(ns). NaN raises ValueError unless ``gaps=True``.
    """
    return _allan("adev", data, rate, data_type, taus, gaps)


def oadev(data, rate=1.0, data_type="phase", taus=None, *, gaps=False):
    """Overlapping Allan deviation, as ``allantools.oadev``: returns ``(taus, devs, errs, ns)`` (see ``adev``)."""
    return _allan("oadev", data, rate, data_type, taus, gaps)


def mdev(data, rate=1.0, data_type="phase", taus=None, *, gaps=False):
    """Modified Allan deviation, as ``allantools.mdev``: returns ``(taus, devs, errs, ns)`` (see ``adev``)."""
    return _allan("mdev", data, rate, data_type, taus, gaps)


def hdev(data, rate=1.0, data_type="phase", taus=None, *, gaps=False):
    """Hadamard deviation, as ``allantools.hdev``: returns ``(taus, devs, errs, ns)`` (see ``adev``)."""
    return _allan("hdev", data, rate, data_type, taus, gaps)


def ohdev(data, rate=1.0, data_type="phase", taus=None, *, gaps=False):
    """Overlapping Hadamard deviation, as ``allantools.ohdev``: returns ``(taus, devs, errs, ns)``."""
    return _allan("ohdev", data, rate, data_type, taus, gaps)


def tdev(data, rate=1.0, data_type="phase", taus=None, *, gaps=False):
    """Time deviation, tau MDEV / sqrt(3), as ``allantools.tdev``: returns ``(taus, devs, errs, ns)``."""
    return _allan("tdev", data, rate, data_type, taus, gaps)


def totdev(data, rate=1.0, data_type="phase", taus=None, *, gaps=False):
    """Total deviation, as ``allantools.totdev``: returns ``(taus, devs, errs, ns)`` (see ``adev``)."""
    return _allan("totdev", data, rate, data_type, taus, gaps)


def deviation(data, rate=1.0, stat="oadev", data_type="freq", taus="octave", confidence=0.683, noise=None,
              *, gaps=False):
    """One statistic as ``octavar analyze`` tabulates it (Stable32's table), as a dict of arrays.

    ``stat`` is adev, oadev, mdev, hdev, ohdev, tdev or totdev. ``data_type`` defaults to ``"freq"``: a gyro's
    samples are rates. ``taus`` is ``"octave"``, ``"decade"``, ``"all"`` (octavar's lists, which stop where
    Stable32's do), a number of taus per decade, or taus in seconds. ``noise`` fixes the power-law alpha behind
    every interval; by default it is identified at each tau.

    Keys: ``m``, ``tau_s``, ``n`` (terms averaged), ``dev``, ``lo`` and ``hi`` (the interval at ``confidence``),
    ``edf``, ``alpha`` (the noise type), ``noise_method``, ``stat`` and ``confidence``.
    """
    if not isinstance(taus, str) and not isinstance(taus, (int, np.integer)):
        taus = _samples(np.asarray(taus, dtype=np.float64).ravel(), "taus")
    return _octavar.deviation(_samples(data), float(rate), str(stat).lower(), data_type, taus, float(confidence),
                              None if noise is None else int(noise), bool(gaps))


def fit(data, rate=1.0, *, confidence=0.95, tau_min=None, tau_max=None, bandwidth=None, terms=None,
        model_error=0.03, quantity="gyro", gaps=False):
    """The IEEE 952 noise terms of a rate record (deg/s, ``rate`` samples per second), as ``octavar analyze``.

    The overlapping Allan deviation at octave tau is fitted with the five-term model; returns a dict: ``N``,
    ``B``, ``K``, ``R`` and ``Q``, each ``{"value", "interval": (lo, hi), "identifiable", "unit", "alt"}`` (a term
    that is not identifiable has no value and its upper bound as the interval's top); ``chi2``, ``dof``,
    ``chi2_per_dof``, ``confidence``, ``tau_range_s``, ``bandwidth_hz``, ``classic`` (the graphical readouts),
    ``squares`` (for ``model_adev``) and ``points`` (the deviations fitted, as ``deviation`` gives them).

    ``tau_min`` and ``tau_max`` (s) bound the taus fitted; ``bandwidth`` (Hz) is a known first-order bandwidth of
    the sensor; ``terms`` limits the model (e.g. ``["N", "B", "K"]``); ``quantity="accel"`` names the units of an
    accelerometer's record (m/s^2).
    """
    return _octavar.fit(_samples(data), float(rate), float(confidence), tau_min, tau_max, bandwidth,
                        None if terms is None else [str(t) for t in terms], float(model_error), quantity, bool(gaps))


def fit_deviations(taus, devs, *, ns=None, edf=None, rate=None, stat="oadev", confidence=0.95, tau_min=None,
                   tau_max=None, bandwidth=None, terms=None, model_error=0.03, quantity="gyro"):
    """The IEEE 952 fit of Allan deviations computed elsewhere; the same dict as ``fit`` (without ``points``).

    Each point needs its degrees of freedom: give ``edf``, or ``ns`` (the terms averaged, as allantools returns)
    and ``rate`` (samples per second), from which the EDF is computed with the noise type read from the curve's
    local slope. With ``ns`` and ``rate`` the intervals also account for the correlation between taus. ``stat``
    is ``"oadev"`` or ``"adev"``: which estimator the deviations are.
    """
    taus = _samples(taus, "taus")
    devs = _samples(devs, "devs")
    return _octavar.fit_deviations(taus, devs, _optional(ns, "ns"), _optional(edf, "edf"),
                                   None if rate is None else float(rate), stat, float(confidence), tau_min, tau_max,
                                   bandwidth, None if terms is None else [str(t) for t in terms], float(model_error),
                                   quantity)


def model_adev(fit_result, taus):
    """The Allan deviation of a fit's model (the dict ``fit`` or ``fit_deviations`` returned) at ``taus`` (s)."""
    sq = fit_result["squares"]
    return _octavar.model_adev([float(sq[t]) for t in ("Q", "N", "B", "K", "R")], fit_result["bandwidth_hz"],
                               _samples(np.asarray(taus, dtype=np.float64).ravel(), "taus"))


def gap(data, rate, temperature=None, holdout=None, *, holdout_temperature=None, holdout_fraction=0.5, seeds=20,
        oversample=1, holdout_check="plain", keep_transients=False, quantity="gyro", gaps=False):
    """The sim-to-real gap diagnosis of a rate record, as ``octavar gap``: returns the dict of its JSON document.

    The later ``holdout_fraction`` of ``data`` is held out, or ``holdout`` (a second record at the same rate)
    is. ``temperature`` (degC, one value per sample) drives the simulated ensemble and the temperature view.
    """
    return _octavar.gap(_samples(data), float(rate), _optional(temperature, "temperature"),
                        _optional(holdout, "holdout"), _optional(holdout_temperature, "holdout_temperature"),
                        float(holdout_fraction), int(seeds), int(oversample), holdout_check, bool(keep_transients),
                        quantity, bool(gaps))


def _names(value):
    if value is None:
        return []
    if isinstance(value, str):
        return [value]
    return [str(v) for v in value]


def read(path, column=None, *, rate=None, time_column=None, unit="deg/s", format=None, topic=None,
         temp_column=None, accel_column=None, accel_unit="m/s^2", skip_rows=0, where=None, delimiter=None,
         decimal_comma=False, flexible=False, channels=1):
    """Read a recording in any format ``octavar analyze`` reads; returns ``(samples, rate)``.

    ``samples`` is a 1-D array for one channel, else ``(n_samples, n_channels)`` in the order asked for (a bag
    read without ``column`` gives x, y, z and ax, ay, az). Rates are in deg/s (``unit`` names the file's) and
    accelerations in m/s^2; a missing sample is NaN. With ``temp_column`` the temperature (degC) comes third:
    ``(samples, rate, temperature)``. The options are the command's flags: ``where`` is a list of
    ``"COLUMN=VALUE"`` filters, ``format`` one of csv, tdms, mcap, db3, bag, capture, f64le, f32le, i16le, u16le.
    """
    channel_arrays, rate_hz, temperature, _names_read, _source = _octavar.read(
        os.fspath(path), _names(column), _names(accel_column), None if rate is None else float(rate), time_column,
        unit, accel_unit, format, topic, temp_column, int(skip_rows), _names(where), delimiter, bool(decimal_comma),
        bool(flexible), int(channels))
    samples = channel_arrays[0] if len(channel_arrays) == 1 else np.column_stack(channel_arrays)
    if temp_column is not None:
        return samples, rate_hz, temperature
    return samples, rate_hz


def simulate(model, duration, seed=0, *, rate=None, analog=False, with_temperature=False):
    """Samples of the virtual bench, as ``octavar simulate`` writes them: each channel's rate in deg/s.

    ``model`` is the path of a ``model.toml`` (``analyze --model-out`` writes one) or a dict of one channel's
    terms: ``n`` (deg/sqrt(s)), ``b`` (deg/s), ``k`` (deg/s/sqrt(s)), ``r`` (deg/s^2), ``q`` (deg), ``bias``
    (deg/s), ``sensor`` and ``rate`` (Hz, 2000 by default). ``duration`` is seconds or text such as ``"6h"``. The
    same seed gives the same samples. The rates are those the ADC reports (``analog=True``: before the ADC).
    Returns a 1-D array for one channel, else ``(n_samples, n_channels)``; with ``with_temperature`` also the
    bench temperature (degC): ``(samples, temperature)``.
    """
    if not isinstance(model, dict):
        model = os.fspath(model)
    if not isinstance(duration, str):
        duration = float(duration)
    channel_arrays, temperature, _rate = _octavar.simulate(model, duration, int(seed),
                                                            None if rate is None else float(rate), bool(analog))
    samples = channel_arrays[0] if len(channel_arrays) == 1 else np.column_stack(channel_arrays)
    if with_temperature:
        return samples, temperature
    return samples
