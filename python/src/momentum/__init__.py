"""momentum: collision detection for robot arms from joint signals, on NumPy arrays.

The library of the momentum tools, compiled in. Each function does what one tool does, with the
same library calls and the same defaults, so that its numbers are the tool's to the last bit:

    read(path)                      a stream (CSV, binary, every encoding mo-cat reads) as columns
    write(path, columns)            columns as a stream (mo-log(5))
    Profile(path)                   a robot profile (momentum-profile(5))
    observe(profile, columns)       mo-observe: the residual columns r, tau_f, mu
    calibrate(profile, [columns])   mo-calibrate: thresholds, written into the profile
    detect(profile, residuals)      mo-detect: events, one record per event row

Columns go in as a Columns, a dict of equal-length arrays, or a pandas DataFrame, or as the
path of a stream. Bad input raises momentum.Error with the library's `file:line: message`;
skipped rows and other warnings are issued as momentum.MomentumWarning (the first 5 of each
kind, then a count, as the tools do).
"""

from __future__ import annotations

import csv
import json
import math
import os
import tempfile
import warnings
from collections.abc import Mapping
from typing import Any, Iterable, Optional, Sequence, Union

import numpy as np

from . import _core
from ._core import Error

__version__ = _core.__version__
__all__ = ["Columns", "Error", "MomentumWarning", "Profile", "Calibration", "Events", "read", "write", "observe",
           "calibrate", "detect", "__version__"]

PathLike = Union[str, "os.PathLike[str]"]
_SHOWN_PER_KIND = 5  # as cli::Tool::kShownPerKind


class MomentumWarning(UserWarning):
    """A warning of the library: a skipped bad row, an observer restart, a calibration note."""


def _issue(collected, stacklevel=3):
    """Issues the library's warnings of one call, the first 5 skipped rows of each kind, then a
    count of the rest (cli::Tool's policy)."""
    by_kind: dict[str, int] = {}
    for kind, message in collected:
        if kind:
            by_kind[kind] = by_kind.get(kind, 0) + 1
            if by_kind[kind] > _SHOWN_PER_KIND:
                continue
        warnings.warn(message, MomentumWarning, stacklevel=stacklevel)
    if by_kind:
        for kind, count in by_kind.items():
            if count > _SHOWN_PER_KIND:
                hidden = count - _SHOWN_PER_KIND
                warnings.warn(f"{hidden} more '{kind}' warning{'' if hidden == 1 else 's'} not shown",
                              MomentumWarning, stacklevel=stacklevel)
        total = sum(by_kind.values())
        kinds = ", ".join(f"{count} {kind}" for kind, count in sorted(by_kind.items()))
        warnings.warn(f"{total} bad row{'' if total == 1 else 's'} skipped: {kinds}", MomentumWarning,
                      stacklevel=stacklevel)


class Columns(Mapping):
    """Named columns of equal length (a stream's), in order: a read-only mapping of name to a
    float64 NumPy array. `columns` lists the names, `rows` the length; `comments` holds the
    stream's leading comment lines."""

    def __init__(self, data: Mapping[str, Any], comments: Sequence[str] = (), encoding: Optional[str] = None):
        self._data = {str(name): np.asarray(values, dtype=np.float64) for name, values in data.items()}
        lengths = {len(v) for v in self._data.values()}
        if len(lengths) > 1:
            raise ValueError(f"columns of different lengths: {sorted(lengths)}")
        for name, values in self._data.items():
            if values.ndim != 1:
                raise ValueError(f"column '{name}': {values.ndim} dimensions, not 1")
        self.comments = list(comments)
        self.encoding = encoding

    @property
    def columns(self) -> list[str]:
        return list(self._data)

    @property
    def rows(self) -> int:
        return len(next(iter(self._data.values()))) if self._data else 0

    def __getitem__(self, name: str) -> np.ndarray:
        return self._data[name]

    def __iter__(self):
        return iter(self._data)

    def __len__(self) -> int:
        return len(self._data)

    def __repr__(self) -> str:
        return f"Columns({self.rows} rows: {', '.join(self._data)})"

    def to_numpy(self) -> np.ndarray:
        """The columns as one (rows, columns) array."""
        return np.column_stack(list(self._data.values())) if self._data else np.empty((0, 0))

    def to_pandas(self):
        """The columns as a pandas DataFrame (needs pandas)."""
        import pandas

        return pandas.DataFrame(dict(self._data))


def _as_columns(columns: Any) -> Columns:
    if isinstance(columns, Columns):
        return columns
    if hasattr(columns, "to_dict") and hasattr(columns, "columns") and hasattr(columns, "__getitem__"):
        return Columns({name: columns[name].to_numpy(dtype=np.float64) for name in columns.columns})  # DataFrame
    if isinstance(columns, np.ndarray) and columns.dtype.names:
        return Columns({name: columns[name] for name in columns.dtype.names})
    if isinstance(columns, Mapping):
        return Columns(columns)
    raise TypeError(f"columns: a Columns, a mapping of name to array or a DataFrame, not {type(columns).__name__}")


def _result(columns: Columns, pandas: bool):
    return columns.to_pandas() if pandas else columns


def read(path: PathLike, *, pandas: bool = False, strict: bool = False, names: Optional[Sequence[str]] = None,
         time_order: bool = True):
    """Reads a whole stream at `path` ("-": standard input) through the library's stream reader:
    every encoding it reads (CSV, binary). Returns Columns, or a pandas DataFrame with pandas=True.

    strict: raise momentum.Error at the first bad row instead of skipping it with a warning.
    names: column names of a CSV file without a header (mo-cat --names; "_" drops a column).
    time_order: apply the suite's time-order policy to the column t (off: mo-cat's rows as written).
    Raises momentum.Error (`file:line: message`) for a file that cannot be read or a bad header."""
    names_list = list(names or [])
    columns, data, comments, encoding, collected = _core.read_stream(os.fspath(path), strict, names_list, time_order, "")
    _issue(collected)
    return _result(Columns(dict(zip(columns, data)), comments, encoding), pandas)


def write(path: PathLike, columns: Any, encoding: str = "csv", comments: Sequence[str] = ()) -> None:
    """Writes `columns` (Columns, a mapping of name to array, a DataFrame) as a stream at `path`
    ("-": standard output), CSV (numbers that read back to the same double) or "binary".
    Raises momentum.Error when the file cannot be written, ValueError for bad columns."""
    c = _as_columns(columns)
    if encoding not in ("csv", "binary", "bin"):
        raise ValueError(f"encoding '{encoding}' is not csv or binary")
    collected = _core.write_stream(os.fspath(path), c.columns, [c[name] for name in c.columns],
                                   encoding, list(comments))
    _issue(collected)


class Profile:
    """A robot profile (man 5 momentum-profile) loaded from `path`, with the chain it builds;
    `payload`: the payload the dynamics include (as the tools' --payload; None: the profile's
    active one, "none": none). Raises momentum.Error naming the file for a bad profile."""

    def __init__(self, path: PathLike, payload: Optional[str] = None):
        self._payload = payload or ""
        loaded, collected = _core.load_profile(os.fspath(path), self._payload)
        _issue(collected)
        self._loaded = loaded

    def reload(self) -> None:
        """Reads the file again (after a calibration wrote it)."""
        self.__init__(self.path, self._payload or None)

    @property
    def path(self) -> str:
        return self._loaded.path

    @property
    def joints(self) -> int:
        """Moving joints of the chain."""
        return self._loaded.joints

    @property
    def joint_names(self) -> list[str]:
        return self._loaded.joint_names

    @property
    def document(self) -> dict:
        """The whole profile document as read (comments dropped)."""
        return json.loads(self._loaded.document)

    def thresholds(self, signal: str = "mu") -> Optional[dict]:
        """The profile's thresholds for `signal` ("mu" or "r"), or None."""
        return self.document.get("thresholds", {}).get(signal)

    def __repr__(self) -> str:
        return f"Profile({self.path!r}, {self.joints} joints)"


def _profile(profile: Union[Profile, PathLike]) -> Profile:
    return profile if isinstance(profile, Profile) else Profile(profile)


def _profile_path(profile: Union[Profile, PathLike, None]) -> str:
    if profile is None:
        return ""
    return profile.path if isinstance(profile, Profile) else os.fspath(profile)


def _stream_input(columns: Any, folder: str, index: int, display: Optional[str]) -> tuple[str, str]:
    """The path a driver reads and its name in messages: a path as it is, columns written to a
    binary stream in `folder` (exact to the bit)."""
    if isinstance(columns, (str, os.PathLike)):
        path = os.fspath(columns)
        return path, display or ""
    c = _as_columns(columns)
    path = os.path.join(folder, f"input-{index}.bin")
    _issue(_core.write_stream(path, c.columns, [c[name] for name in c.columns], "binary", c.comments), 4)
    return path, display or (f"<columns {index + 1}>" if index else "<columns>")


def _provenance(what: str) -> str:
    return f"momentum-python {__version__} {what}"


def _list(values) -> Optional[list[float]]:
    if values is None:
        return None
    if isinstance(values, (int, float)):
        return [float(values)]
    return [float(v) for v in values]


def observe(profile: Union[Profile, PathLike], columns: Any, *, order: Optional[int] = None, k1=None, k2=None,
            k3=None, cutoff=None, gap_factor: Optional[float] = None, bridge_tolerance: Optional[float] = None,
            signal_check: bool = True, signal_sigmas: Optional[float] = None, limit_factor: Optional[float] = None,
            flag_column: bool = False, friction: bool = True, friction_deadband: Optional[float] = None,
            friction_cutoff: Optional[float] = None, lugre_update: Optional[str] = None,
            restart_column: bool = False, strict: bool = False, name: Optional[str] = None, pandas: bool = False):
    """mo-observe: the generalized-momentum observer over `columns` (t, q<j>, dq<j>, tau_m<j> or
    i<j>; or the path of a stream). Returns every input column, then r<j> (and tau_f<j>, mu<j>
    with the profile's friction model, `restart`, `flagged` when asked), as mo-observe writes them.

    Options as mo-observe's (man mo-observe), None: the profile's or the tool's default: order
    (1 or 2), k1/k2/k3 (1/s, one value or one per joint), cutoff (Hz, k1 = 2 pi cutoff),
    gap_factor, bridge_tolerance (rad), signal_check=False (--no-signal-check), signal_sigmas,
    limit_factor, flag_column, friction=False (--no-friction), friction_deadband (rad/s),
    friction_cutoff (Hz), lugre_update ("exact" or "semi-implicit"), restart_column, strict.
    name: the input's name in messages. The result's `summary` holds the run's counts (rows
    written, invalid, rejected and flagged rows, restarts, bridged gaps, the median time step).
    Raises momentum.Error for a stream that does not fit the profile, ValueError for bad
    options."""
    p = _profile(profile)
    a = _core.ObserveArguments()
    a.order = order
    a.k1, a.k2, a.k3, a.cutoff = _list(k1), _list(k2), _list(k3), _list(cutoff)
    a.gap_factor, a.bridge_tolerance = gap_factor, bridge_tolerance
    a.signal_check, a.signal_sigmas, a.limit_factor = signal_check, signal_sigmas, limit_factor
    a.flag_column, a.friction, a.restart_column, a.strict = flag_column, friction, restart_column, strict
    a.friction_deadband, a.friction_cutoff, a.lugre_update = friction_deadband, friction_cutoff, lugre_update or ""
    with tempfile.TemporaryDirectory(prefix="momentum-") as folder:
        path, display = _stream_input(columns, folder, 0, name)
        output = os.path.join(folder, "observed.bin")
        summary, collected = _core.observe_stream(p._loaded, path, display, output, a, [_provenance("observe")])
        _issue(collected)
        columns_out, data, comments, _, collected = _core.read_stream(output, True, [], False, "")
        _issue(collected)
    result = Columns(dict(zip(columns_out, data)), comments, "bin")
    result.summary = summary
    return _result(result, pandas)


class Events(list):
    """detect()'s records, in order, with `summary`: the run's counts (rows, seconds, events,
    collisions, rows_skipped, blind_seconds, blind_share, blind_text)."""

    summary: dict = {}


class Calibration:
    """What calibrate() found: `thresholds`, per signal ("mu", "r") the thresholds section as
    mo-calibrate writes it into the profile; `report`, mo-calibrate's report; `rows`, the good
    rows calibrated on."""

    def __init__(self, thresholds: dict, report: str, rows: int):
        self.thresholds = thresholds
        self.report = report
        self.rows = rows

    def __repr__(self) -> str:
        return f"Calibration({', '.join(self.thresholds)}; {self.rows} rows)"


def calibrate(profile: Union[Profile, PathLike, None], column_sets: Iterable[Any], *, output: Optional[PathLike] = None,
              dry_run: bool = False, signal: Optional[str] = None, rule: str = "rate",
              false_alarm_rate: Optional[float] = None, peak_window: Optional[float] = None,
              max_rise: float = 0, margin: Optional[float] = None, margin_percent: Optional[float] = None,
              envelope: bool = False, envelope_bin: Optional[float] = None, rest_velocity: Optional[float] = None,
              rest_time: Optional[float] = None, hangover: Optional[float] = None, skip: Optional[float] = None,
              stretch_gap: Optional[float] = None, rest_drift=None, contact_rise: Optional[float] = None,
              rest_signal: str = "r", no_rest: bool = False, contact_ratio: Optional[float] = None,
              reject_contact: bool = False, friction_band: Optional[float] = None, format: str = "text",
              strict: bool = False, names: Optional[Sequence[str]] = None) -> Calibration:
    """mo-calibrate: collision-free residual streams (each a set of columns with t, mu<j> and/or
    r<j>, dq<j>; or a path) in, thresholds per joint and motion state out. As the tool, the
    profile is updated in place unless `output` names another file or dry_run; profile None:
    the report only. Options as mo-calibrate's (man mo-calibrate), None: its default. names:
    the streams' names in the report and messages. Raises momentum.Error as the tool fails
    (too few rows, a check that refuses the update), ValueError for bad options."""
    a = _core.CalibrateArguments()
    a.signal, a.rule, a.rest_signal, a.format = signal or "", rule, rest_signal, format
    a.false_alarm_rate, a.peak_window, a.margin, a.margin_percent = false_alarm_rate, peak_window, margin, margin_percent
    a.envelope_bin, a.rest_velocity, a.rest_time, a.hangover = envelope_bin, rest_velocity, rest_time, hangover
    a.skip, a.stretch_gap, a.contact_ratio, a.friction_band = skip, stretch_gap, contact_ratio, friction_band
    a.contact_rise, a.rest_drift, a.max_rise = contact_rise, _list(rest_drift), max_rise
    a.envelope, a.no_rest, a.reject_contact, a.strict = envelope, no_rest, reject_contact, strict
    sets = list(column_sets)
    if not sets:
        raise ValueError("calibrate needs at least one set of columns")
    if isinstance(column_sets, (str, os.PathLike, Mapping)):
        raise TypeError("column_sets: a list of column sets or paths")
    names = list(names) if names is not None else [None] * len(sets)
    if len(names) != len(sets):
        raise ValueError(f"{len(names)} names for {len(sets)} column sets")
    profile_path = _profile_path(profile)
    with tempfile.TemporaryDirectory(prefix="momentum-") as folder:
        paths, displays = zip(*(_stream_input(c, folder, i, n) for i, (c, n) in enumerate(zip(sets, names))))
        displays = [d or p for p, d in zip(paths, displays)]
        thresholds, report, rows, collected = _core.calibrate_streams(
            profile_path, list(paths), displays, os.fspath(output) if output is not None else "", dry_run, a)
    _issue(collected)
    if isinstance(profile, Profile) and output is None and not dry_run:
        profile.reload()
    return Calibration({s: json.loads(text) for s, text in thresholds}, report, rows)


_EVENT_INTEGERS = {"link", "event"}
_EVENT_TEXT = {"kind", "ended_by", "class", "seen"}


def _event_record(row: dict) -> dict:
    record = {}
    for key, text in row.items():
        if key in _EVENT_TEXT:
            record[key] = text
        elif key in _EVENT_INTEGERS:
            record[key] = int(text)
        elif key in ("joints", "link_set"):
            record[key] = tuple(int(j) for j in text.split(";") if j)
        elif key == "links":
            # "link:probability;...", most probable first: a dict keeps that order.
            record[key] = {int(link): float(p) for link, p in (item.split(":") for item in text.split(";") if item)}
        else:
            record[key] = float(text) if text else math.nan
    return record


def detect(profile: Union[Profile, PathLike, None], residuals: Any, *, signal: Optional[str] = None, threshold=None,
           constant: bool = False, min_samples: Optional[int] = None, release: Optional[float] = None,
           hold: Optional[float] = None, join: Optional[float] = None, aftermath: Optional[float] = None,
           onset_band: Optional[float] = None, skip: Optional[float] = None, identify: bool = True,
           link_radius: Optional[float] = None, strict: bool = False, name: Optional[str] = None,
           pandas: bool = False):
    """mo-detect: collision events from residual columns (mo-observe's output, or a path) with
    the profile's thresholds (or constant ones: threshold, Nm, one or one per joint). Returns
    mo-detect's event rows as records, in order: a list of dicts with the keys of its event
    format (man mo-detect, EVENT FORMAT): t_onset_estimate, t_detect, link, joints (a tuple),
    kind ("onset" or "end"), event, t_end, ended_by, peak<j>, and the contact columns with a
    model and q (links: a dict link -> probability, most probable first; link_set: a tuple);
    empty fields are NaN or "". The list is an Events, whose `summary` holds the
    run's counts (rows, events, collisions, blind time); pandas=True: a DataFrame instead. Options as mo-detect's; identify=False
    is --no-identify. Raises momentum.Error as the tool fails (exit status 2)."""
    a = _core.DetectArguments()
    a.signal, a.threshold, a.constant, a.identify, a.strict = signal or "", _list(threshold), constant, identify, strict
    a.min_samples, a.release, a.hold, a.join = min_samples, release, hold, join
    a.aftermath, a.onset_band, a.skip, a.link_radius = aftermath, onset_band, skip, link_radius
    with tempfile.TemporaryDirectory(prefix="momentum-") as folder:
        path, display = _stream_input(residuals, folder, 0, name)
        events = os.path.join(folder, "events.csv")
        summary, collected = _core.detect_stream(_profile_path(profile), path, display, events, a, [])
        _issue(collected)
        with open(events, newline="") as f:
            records = Events(_event_record(row) for row in csv.DictReader(line for line in f if not line.startswith("#")))
    records.summary = summary
    if pandas:
        import pandas as pd

        return pd.DataFrame.from_records(records)
    return records
