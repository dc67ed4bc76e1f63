"""stickslip: where tangential substrate vibration suppresses stick-slip friction.

The Python face of the ``stickslip`` engine. Every function goes through the same validation and
the same code as the command-line tool, so a run gives the numbers ``stickslip run --json`` gives
and a sweep the file ``stickslip sweep`` writes; results come back as :mod:`xarray` and
:mod:`pandas` objects.

Units are SI throughout (m, s, N, Hz); each result carries its units in ``attrs``.

>>> import stickslip
>>> run = stickslip.run(k_d=10_000, v_d=1e-3, f=1500, va_ratio=0.4)
>>> run.r                                   # dF with vibration / dF without  # doctest: +SKIP
0.59...
>>> run.trace.F_d.plot()                    # the drive force against time  # doctest: +SKIP

Errors: bad input raises :class:`ValueError` with the CLI's message word for word; a run or
sweep that fails raises :class:`RuntimeError`; Ctrl-C stops the computation within a second
(:class:`KeyboardInterrupt`; a sweep keeps every finished run for ``resume=True``).
"""

from __future__ import annotations

import json
import math
import os
import tempfile
import tomllib
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any, Callable, Mapping, Optional, Sequence, Union

import numpy as np
import pandas as pd
import xarray as xr

from . import _native

__all__ = [
    "run",
    "Run",
    "sweep",
    "open",
    "boundary",
    "Campaign",
    "calibrate",
    "Calibration",
    "diagnose",
    "Diagnosis",
    "plan",
    "Plan",
    "parameters",
    "__version__",
]

__version__: str = _native.version()

PathLike = Union[str, "os.PathLike[str]"]

#: name -> (CLI flag, unit, default, meaning) of every model parameter.
_PARAMS: dict[str, tuple[str, str, float, str]] = {
    name: (flag, unit, default, doc) for name, flag, unit, default, doc in _native.parameters()
}


def parameters() -> pd.DataFrame:
    """The model's parameters: name, unit, default value and meaning (SI units).

    Every one of them is a keyword of :func:`run` and a key of a sweep's ``fixed`` table or
    an ``axis`` name.
    """
    rows = [
        {"name": n, "unit": u, "default": d, "meaning": doc} for n, (_, u, d, doc) in _PARAMS.items()
    ]
    return pd.DataFrame(rows).set_index("name")


def _number(name: str, value: Any) -> str:
    """A float as the CLI reads it back to the same bits (``repr`` is the shortest round trip)."""
    if isinstance(value, bool) or not isinstance(value, (int, float, np.integer, np.floating)):
        raise ValueError(f"{name} = {value!r}: must be a number")
    return repr(float(value))


def _effect_specs(effects: Any) -> list[str]:
    """``{"aging": {"b": 0.03}}``, ``["aging"]`` or ``"aging:b=0.03"`` as ``--effect`` values."""
    if effects is None:
        return []
    if isinstance(effects, str):
        return [effects]
    if isinstance(effects, Mapping):
        out = []
        for name, params in effects.items():
            params = params or {}
            if not isinstance(params, Mapping):
                raise ValueError(
                    f"effects[{name!r}] = {params!r}: must be a dict of parameters (or None)"
                )
            kv = ",".join(f"{k}={_number(f'{name}.{k}', v)}" for k, v in params.items())
            out.append(f"{name}:{kv}" if kv else str(name))
        return out
    return [str(e) for e in effects]


def _trace_dataset(arrays: Mapping[str, np.ndarray]) -> xr.Dataset:
    units = {n: (u, doc) for n, u, doc in _native.trace_channels()}
    t = arrays["t"]
    data = {}
    for name, values in arrays.items():
        if name == "t":
            continue
        unit, doc = units.get(name, ("", name))
        data[name] = xr.Variable(("t",), values, {"units": unit, "long_name": doc})
    unit, doc = units["t"]
    return xr.Dataset(data, coords={"t": xr.Variable(("t",), t, {"units": unit, "long_name": doc})})


@dataclass(frozen=True)
class Run:
    """One case and its reference without vibration, as ``stickslip run --json`` reports it.

    Attributes are the JSON's fields: ``r`` (reduction coefficient, dF with over dF without
    vibration, Eq. 5.1), ``r_stderr``, ``dF`` [N] (mean stick-slip drop of the smoothed drive
    force) and ``dF_stderr`` [N] (the standard errors ``None`` where the window holds a single
    cycle), ``mean_force`` [N], ``stick_fraction``, ``period`` [s],
    ``status``, ``stats`` (steps, rejections, right-hand sides, Jacobians, LU factorisations),
    ``params`` (every parameter, SI), ``reference`` (the run without vibration) and more: see
    :meth:`to_dict`. ``trace`` is the time series as an :class:`xarray.Dataset` (``None`` when
    run with ``trace=False``).
    """

    json: dict[str, Any]
    trace: Optional[xr.Dataset] = field(default=None, repr=False)

    def __getattr__(self, name: str) -> Any:
        try:
            return self.json[name]
        except KeyError:
            raise AttributeError(name) from None

    def to_dict(self) -> dict[str, Any]:
        """The JSON object of ``stickslip run --json``, as a dict."""
        return dict(self.json)

    def __repr__(self) -> str:
        j = self.json
        return (
            f"Run(status={j['status']!r}, r={j['r']}, dF={j['dF']} N, "
            f"mean_force={j['mean_force']} N, v_a/v_d={j['va_ratio']})"
        )


def run(
    *,
    u0: Optional[float] = None,
    v_a: Optional[float] = None,
    va_ratio: Optional[float] = None,
    method: Optional[str] = None,
    rtol: Optional[float] = None,
    atol: Optional[float] = None,
    t_end: Optional[float] = None,
    min_cycles: Optional[int] = None,
    early_stop: Union[bool, str, None] = None,
    periodic: bool = True,
    envelope: Union[float, bool, None] = None,
    tier: Optional[str] = None,
    effects: Any = None,
    case: Optional[PathLike] = None,
    trace: bool = True,
    **params: float,
) -> Run:
    """Simulates one case and its reference without vibration.

    Parameters
    ----------
    u0, v_a, va_ratio:
        The vibration amplitude: displacement ``u0`` [m], velocity amplitude
        ``v_a = 2 pi f u0`` [m/s], or ``v_a / v_d`` [-]; at most one. Default: no vibration.
    method:
        ``"auto"`` (default: Dormand-Prince 5(4) handing stiff stretches to Radau IIA),
        ``"radau5"``, ``"rodas4"`` or ``"dopri5"``.
    rtol, atol:
        Tolerances (default 1e-6; ``atol`` in units of each state's characteristic size).
    t_end:
        Simulated time [s]; default chosen so that the steady window (the second half) holds
        ``min_cycles`` (default 3) stick-slip cycles of the run without vibration.
    early_stop:
        ``False`` runs the whole automatic time; ``"always"`` (or ``True``) also ends a run with
        ``t_end`` given once its answer is known. Default: end automatic runs early.
    periodic:
        Without vibration, continue along the limit cycle once two slips repeat (default True).
    envelope:
        Envelope-following tolerance (default 1e-4); ``False`` integrates every period.
    tier:
        Which model serves a run with vibration: ``"auto"`` (default: the vibration averaged
        out where the averaged law is valid, hybrid windows where the run passes zones where it
        is not, else the full model), ``"averaged"``, ``"hybrid"`` (the averaged law with the
        full model in windows where it is not valid) or ``"full"``.
        ``Run.tier`` and ``Run.tier_reason`` say which served and why.
    effects:
        Model extensions: ``{"aging": {"b": 0.03}}``, ``["viscous"]`` or ``"aging:b=0.03"``.
    case:
        A case file (TOML) read first; keywords override it.
    trace:
        Keep the time series (``Run.trace``); default True.
    **params:
        Any model parameter by name in SI units: ``k_d`` [N/m], ``v_d`` [m/s], ``f`` [Hz],
        ``t_on`` [s], ``F_s`` [N], ``h_d`` [N s/m], ... (:func:`parameters` lists them).

    Raises
    ------
    ValueError
        Bad input, with the CLI's message.
    RuntimeError
        The run did not succeed (its status and, when unsettled, the time it needs).
    """
    args: list[str] = []
    if case is not None:
        args += ["--case", os.fspath(case)]
    for name, value in params.items():
        if name not in _PARAMS:
            raise ValueError(
                f"unknown parameter {name!r}; allowed: "
                + ", ".join(["v_a", "va_ratio", *_PARAMS])
            )
        args += [f"--{_PARAMS[name][0]}", _number(name, value)]
    given = [(n, v) for n, v in (("u0", u0), ("v_a", v_a), ("va_ratio", va_ratio)) if v is not None]
    if len(given) > 1:
        raise ValueError(
            f"{' and '.join(n for n, _ in given)} given together: give one amplitude "
            "(u0 [m], v_a [m/s] or va_ratio = v_a / v_d)"
        )
    for name, value in given:
        args += ["--" + name.replace("_", "-"), _number(name, value)]
    if method is not None:
        args += ["--solver", str(method)]
    for name, value in (("rtol", rtol), ("atol", atol), ("t-end", t_end)):
        if value is not None:
            args += [f"--{name}", _number(name.replace("-", "_"), value)]
    if min_cycles is not None:
        if isinstance(min_cycles, bool) or not isinstance(min_cycles, (int, np.integer)):
            raise ValueError(f"min_cycles = {min_cycles!r}: must be a whole number from 1 to 1000")
        args += ["--min-cycles", str(int(min_cycles))]
    if early_stop is False:
        args.append("--no-early-stop")
    elif early_stop is True or early_stop == "always":
        args.append("--early-stop")
    elif early_stop is not None:
        raise ValueError(f"early_stop = {early_stop!r}: must be True, False, \"always\" or None")
    if not periodic:
        args.append("--no-periodic")
    if envelope is False:
        args.append("--no-envelope")
    elif envelope is not None and envelope is not True:
        args += ["--envelope", _number("envelope", envelope)]
    if tier is not None:
        if tier not in ("auto", "averaged", "hybrid", "full"):
            raise ValueError(
                f"tier = {tier!r}: must be \"auto\", \"averaged\", \"hybrid\" or \"full\""
            )
        args += ["--tier", tier]
    for spec in _effect_specs(effects):
        args += ["--effect", spec]
    if not trace:
        args.append("--no-trace")
    text, arrays = _native.run(args)
    return Run(json.loads(text), _trace_dataset(arrays) if arrays is not None else None)


def _open_file(path: PathLike) -> xr.Dataset:
    with xr.open_dataset(os.fspath(path), engine="h5netcdf") as ds:
        return ds.load()


def _open_groups(path: PathLike) -> xr.Dataset:
    """A file whose datasets carry no dimension scales (a diagnosis, a benchmark): every dataset
    under its path (``recordings/gap_base`` as ``recordings/gap_base``), the datasets of one
    group with the same shape sharing their dimensions, attributes kept."""
    import h5py

    def text(v: Any) -> Any:
        return v.decode() if isinstance(v, bytes) else v

    data: dict[str, xr.Variable] = {}
    with h5py.File(os.fspath(path), "r") as f:
        attrs = {k: text(v) for k, v in f.attrs.items()}

        def visit(name: str, obj: Any) -> None:
            if isinstance(obj, h5py.Dataset):
                value = obj[()]
                if isinstance(value, bytes):
                    value = value.decode()
                group = name.rpartition("/")[0] or "root"
                dims = tuple(f"{group}_dim{i}_{n}" for i, n in enumerate(np.shape(value)))
                data[name] = xr.Variable(dims, value, {k: text(v) for k, v in obj.attrs.items()})

        f.visititems(visit)
    ds = xr.Dataset(data, attrs=attrs)
    ds.encoding["source"] = os.fspath(path)
    return ds


def open(path: PathLike) -> xr.Dataset:  # noqa: A001 - the package's verb, as xarray's
    """Opens any HDF5 file the CLI writes as an :class:`xarray.Dataset`, loaded into memory.

    A sweep file gives its measures (``r``, ``dF``, ``mean_force``, ``status``, ...) over the
    sweep's axes as named coordinates, exactly as ``xarray.open_dataset(path,
    engine="h5netcdf")`` does; a run's file gives its traces over ``t``; other files (a
    diagnosis, a benchmark) every dataset by its path.
    """
    p = Path(path)
    if not p.is_file():
        raise ValueError(f"{p}: no such file")
    try:
        ds = _open_file(p)
    except (ValueError, OSError, KeyError, TypeError):
        return _open_groups(p)
    if ds.data_vars:
        return ds
    if "trace" in _groups(p):
        # A run's file: its results are the root's attributes, its traces the data, over t.
        import h5py

        with h5py.File(p, "r") as f:
            arrays = {k: v[()] for k, v in f["trace"].items()}
        out = _trace_dataset(arrays)
        out.attrs.update(ds.attrs)
        out.encoding["source"] = os.fspath(p)
        return out
    # Groups only (a diagnosis, a benchmark): every dataset by its path.
    return _open_groups(p)


def _groups(path: Path) -> list[str]:
    import h5py

    with h5py.File(path, "r") as f:
        return [k for k in f.keys() if isinstance(f[k], h5py.Group)]


class _Bar:
    """A tqdm bar (notebook or terminal) drawn from the sweep's counts, created on the first
    count, so that a sweep refused before it starts shows none."""

    def __init__(self) -> None:
        self.bar: Any = None

    def __call__(self, done: int, total: int, failed: int) -> None:
        if self.bar is None:
            from tqdm.auto import tqdm

            self.bar = tqdm(total=total, initial=done, unit="run", desc="sweep", dynamic_ncols=True)
        if self.bar.total != total:
            self.bar.total = total
        self.bar.n = done
        self.bar.set_postfix_str(f"{failed} failed", refresh=False)
        self.bar.refresh()

    def close(self) -> None:
        if self.bar is not None:
            self.bar.close()


def sweep(
    spec: Union[PathLike, Mapping[str, Any]],
    threads: Optional[int] = None,
    out: Optional[PathLike] = None,
    resume: bool = False,
    overwrite: bool = False,
    progress: bool = True,
    figures: bool = False,
) -> xr.Dataset:
    """Runs a sweep in parallel and returns its maps as an :class:`xarray.Dataset`.

    Parameters
    ----------
    spec:
        A sweep file (TOML, as ``stickslip sweep`` reads) or the same content as a dict, e.g.
        ``{"fixed": {"k_d": 11700, "f": 1500}, "axis": [{"name": "va_ratio", "linspace": [0, 4,
        9]}]}``.
    threads:
        Worker threads (1 to 1024); default one per core.
    out:
        The HDF5 file to write, which the CLI's commands read (``status``, ``plot``,
        ``boundary``); default a temporary file, removed once loaded.
    resume:
        Continue an interrupted sweep at ``out`` from its journal.
    overwrite:
        Discard an unfinished sweep's journal at ``out`` and start afresh.
    progress:
        Show a tqdm progress bar (in a notebook or a terminal).
    figures:
        Also draw the CLI's figures beside ``out`` (PNG and SVG).

    Returns
    -------
    xarray.Dataset
        Exactly what ``xarray.open_dataset(out, engine="h5netcdf")`` gives on the file
        ``stickslip sweep`` writes (with its elimination boundary in the file's group
        ``boundary``: :func:`boundary`), loaded into memory.
    """
    if isinstance(spec, Mapping):
        body = dict(spec)
        body.setdefault("name", "sweep")
        text = _native.sweep_toml(json.dumps(body, allow_nan=True))
        file, toml_text = "sweep (dict)", text
    else:
        p = Path(spec)
        file, toml_text = os.fspath(p), None
    if threads is not None and (isinstance(threads, bool) or not isinstance(threads, (int, np.integer))):
        raise ValueError(f"--threads = {threads!r}: must be from 1 to 1024")
    tmp: Optional[tempfile.TemporaryDirectory[str]] = None
    if out is None:
        if resume:
            raise ValueError("resume=True needs out: the file of the sweep to continue")
        tmp = tempfile.TemporaryDirectory(prefix="stickslip-sweep-")
        target = os.path.join(tmp.name, "sweep.h5")
    else:
        target = os.fspath(out)
    bar = _Bar() if progress else None
    try:
        _native.sweep(
            file, toml_text, target, threads, resume, overwrite, figures, bar
        )
        ds = _open_file(target)
        if tmp is not None:
            # The file goes with the temporary folder: its boundary stays with the Dataset
            # (in `encoding`, which comparisons of Datasets ignore).
            ds.encoding.pop("source", None)
            ds.encoding["stickslip_boundary"] = _boundary_table(target)
        return ds
    finally:
        if bar is not None:
            bar.close()
        if tmp is not None:
            tmp.cleanup()


def _boundary_table(path: str) -> dict[str, Any]:
    """The boundary's columns and rows, or the reason there is none (kept for a Dataset whose
    temporary file is gone, and raised when the boundary is asked for)."""
    try:
        names, rows = _native.boundary(path)
    except ValueError as e:
        return {"error": str(e)}
    return {"columns": names, "rows": rows}


def boundary(data: Union[xr.Dataset, PathLike]) -> pd.DataFrame:
    """The elimination boundary (``r = 0.05``) of a sweep, as the CSV ``stickslip boundary``
    writes: per line of the other axes, ``u0_boundary [m]`` (the smallest amplitude that
    eliminates stick-slip), ``v_a_boundary [m/s]``, ``va_ratio_boundary``, the rule of thumb
    ``u0 = v_d / (2 pi f)``, ``below_grid``, ``u0_upper [m]`` (above it every computed amplitude
    eliminates), ``crossings`` and ``resolution``.

    ``data`` is a sweep file or a Dataset from :func:`sweep` or :func:`open`.
    """
    if isinstance(data, xr.Dataset):
        if "stickslip_boundary" in data.encoding:
            table = data.encoding["stickslip_boundary"]
        else:
            source = data.encoding.get("source")
            if not source:
                raise ValueError(
                    "this Dataset does not come from a sweep file: give the file's path, or a "
                    "Dataset from stickslip.sweep or stickslip.open"
                )
            table = _boundary_table(source)
    else:
        table = _boundary_table(os.fspath(data))
    if "error" in table:
        raise ValueError(table["error"])
    df = pd.DataFrame(table["rows"], columns=table["columns"])
    for col in ("below_grid",):
        if col in df:
            df[col] = df[col].astype(bool)
    if "crossings" in df:
        df["crossings"] = df["crossings"].astype(int)
    return df


# ---------------------------------------------------------------------------------------------
# Campaigns: measured recordings
# ---------------------------------------------------------------------------------------------

_CHANNELS = ("t", "F_d", "x_s", "x_d")


def _toml_value(key: str, v: Any) -> str:
    if isinstance(v, bool):
        return "true" if v else "false"
    if isinstance(v, (int, np.integer)):
        return str(int(v))
    if isinstance(v, (float, np.floating)):
        x = float(v)
        if math.isnan(x):
            return "nan"
        if math.isinf(x):
            return "inf" if x > 0 else "-inf"
        return repr(x)
    if isinstance(v, str):
        return json.dumps(v)
    raise ValueError(f"{key} = {v!r}: a condition is a number, a boolean or a string")


def _toml_table(conditions: Mapping[str, Any]) -> str:
    lines = []
    for k, v in conditions.items():
        if not isinstance(k, str) or not k.replace("_", "").isalnum():
            raise ValueError(f"condition name {k!r}: letters, digits and underscores only")
        lines.append(f"{k} = {_toml_value(k, v)}")
    return "\n".join(lines) + "\n"


class Campaign:
    """A measurement campaign: recordings, each a table of ``t`` [s], ``F_d`` [N] and where
    recorded ``x_s`` and ``x_d`` [m], with its conditions (``v_d``, ``k_d``, ``f``, ``u0`` or
    ``v_a`` or ``va_ratio``, optionally ``t_on`` and any model parameter, SI units).

    Build one from pandas frames with :meth:`from_frames`, or read a folder with
    :meth:`from_dir`; :meth:`to_dir` writes the folder ``stickslip calibrate`` and
    ``stickslip diagnose`` read (``NAME.csv`` and ``NAME.toml`` per recording).
    """

    def __init__(
        self,
        recordings: Mapping[str, tuple[pd.DataFrame, Mapping[str, Any]]],
        defaults: Optional[Mapping[str, Any]] = None,
    ) -> None:
        self.recordings: dict[str, tuple[pd.DataFrame, dict[str, Any]]] = {}
        for name, item in recordings.items():
            if not isinstance(name, str) or not name or "/" in name or "\\" in name or name.startswith("."):
                raise ValueError(f"recording name {name!r}: a file stem (not empty, no / or \\, not starting with .)")
            if not (isinstance(item, tuple) and len(item) == 2):
                raise ValueError(f"recording {name!r}: give (DataFrame, conditions)")
            frame, cond = item
            if not isinstance(frame, pd.DataFrame):
                raise ValueError(f"recording {name!r}: {type(frame).__name__} is no pandas DataFrame")
            for col in ("t", "F_d"):
                if col not in frame.columns:
                    raise ValueError(f"recording {name!r}: column {col!r} missing (columns t [s] and F_d [N] are needed; x_s, x_d [m] where recorded)")
            self.recordings[name] = (frame, dict(cond))
        self.defaults = dict(defaults or {})
        self._dir: Optional[tempfile.TemporaryDirectory[str]] = None

    @classmethod
    def from_frames(
        cls,
        recordings: Mapping[str, tuple[pd.DataFrame, Mapping[str, Any]]],
        defaults: Optional[Mapping[str, Any]] = None,
    ) -> "Campaign":
        """A campaign from ``{name: (DataFrame, conditions)}``; ``defaults`` hold conditions
        shared by every recording (``campaign.toml``)."""
        return cls(recordings, defaults)

    @classmethod
    def from_dir(cls, path: PathLike) -> "Campaign":
        """Reads a campaign folder (``NAME.csv`` + ``NAME.toml`` per recording, optional
        ``campaign.toml``) after checking it as the CLI does."""
        _native.check_campaign(os.fspath(path))
        p = Path(path)
        defaults = {}
        if (p / "campaign.toml").is_file():
            defaults = tomllib.loads((p / "campaign.toml").read_text())
        recs = {}
        for toml in sorted(p.glob("*.toml")):
            if toml.name == "campaign.toml":
                continue
            frame = pd.read_csv(toml.with_suffix(".csv"), encoding="utf-8-sig")
            recs[toml.stem] = (frame, tomllib.loads(toml.read_text()))
        return cls(recs, defaults)

    def __len__(self) -> int:
        return len(self.recordings)

    def __repr__(self) -> str:
        return f"Campaign({len(self)} recordings: {', '.join(list(self.recordings)[:6])}{', ...' if len(self) > 6 else ''})"

    def to_dir(self, path: PathLike) -> Path:
        """Writes the campaign as a folder the CLI reads and returns its path.

        The folder is created; an existing file of the same name is never replaced (ValueError).
        The columns ``t``, ``F_d``, ``x_s``, ``x_d`` are written at full precision.
        """
        p = Path(path)
        names = [f"{n}.csv" for n in self.recordings] + [f"{n}.toml" for n in self.recordings]
        if self.defaults:
            names.append("campaign.toml")
        clash = [n for n in names if (p / n).exists()]
        if clash:
            raise ValueError(
                f"{p}: {', '.join(clash[:5])} already there; a campaign is never written over "
                "files: give a new or empty folder"
            )
        p.mkdir(parents=True, exist_ok=True)
        for name, (frame, cond) in self.recordings.items():
            cols = [c for c in _CHANNELS if c in frame.columns]
            frame[cols].to_csv(p / f"{name}.csv", index=False, float_format="%.17g")
            (p / f"{name}.toml").write_text(_toml_table(cond))
        if self.defaults:
            (p / "campaign.toml").write_text(_toml_table(self.defaults))
        _native.check_campaign(os.fspath(p))
        return p

    def _folder(self) -> str:
        """The campaign on disk, in a temporary folder kept as long as the object."""
        if self._dir is None:
            tmp = tempfile.TemporaryDirectory(prefix="stickslip-campaign-")
            self.to_dir(Path(tmp.name) / "campaign")
            self._dir = tmp
        return os.path.join(self._dir.name, "campaign")


def _campaign_dir(campaign: Union[Campaign, PathLike]) -> str:
    if isinstance(campaign, Campaign):
        return campaign._folder()
    return os.fspath(campaign)


class _Report:
    """A JSON report whose fields read as attributes."""

    json: dict[str, Any]
    summary: str

    def __getattr__(self, name: str) -> Any:
        if name in ("json", "summary"):
            raise AttributeError(name)
        try:
            return self.json[name]
        except KeyError:
            raise AttributeError(name) from None

    def __dir__(self) -> list[str]:
        return sorted(set(super().__dir__()) | set(self.json))

    def to_dict(self) -> dict[str, Any]:
        """The JSON object the CLI writes, as a dict."""
        return json.loads(json.dumps(self.json))

    def __str__(self) -> str:
        return self.summary


class Calibration(_Report):
    """The estimates of ``stickslip calibrate`` (``F_s``, ``F_c``, ``v_s``, ``h_d`` and an
    effect's parameters, with uncertainties), as attributes and :meth:`to_dict`; ``summary`` is
    the printed report."""

    def __init__(self, data: dict[str, Any], summary: str) -> None:
        self.json = data
        self.summary = summary

    def __repr__(self) -> str:
        return f"Calibration({', '.join(self.json)})"


def calibrate(
    campaign: Union[Campaign, PathLike],
    effect: Optional[str] = None,
    max_iter: int = 12,
    skip_implausible: bool = False,
) -> Calibration:
    """Fits ``F_s``, ``F_c``, ``v_s``, ``h_d`` (and ``effect``'s parameters) to a campaign's
    recordings, as ``stickslip calibrate``."""
    args = [_campaign_dir(campaign), "--max-iter", str(max_iter)]
    if effect is not None:
        args += ["--effect", str(effect)]
    if skip_implausible:
        args.append("--skip-implausible")
    text, summary = _native.calibrate(args)
    return Calibration(json.loads(text), summary)


class Diagnosis(_Report):
    """The verdict of ``stickslip diagnose``: the JSON's fields as attributes (``verdict``,
    ``best_effect``, ``effects``, ``partial``, ``tie``, ``evidence``, ``gap_before``,
    ``gap_after``, ``reduction``, ``ranking`` (each with its ``fingerprints``), ``rejected``,
    ``where``, ``bounds``, ...), :meth:`to_dict`, the printed report as ``summary``, and the
    report's figures as matplotlib figures (:meth:`figures`)."""

    def __init__(self, data: dict[str, Any], summary: str, out: str, written: Sequence[str]) -> None:
        self.json = data
        self.summary = summary
        self.out = out
        self.files = list(written)
        self._figure_data = _diagnosis_figure_data(os.path.join(out, "diagnosis.h5"))

    def __repr__(self) -> str:
        j = self.json
        return f"Diagnosis(verdict={j.get('verdict')!r}, effects={j.get('effects')!r}, partial={j.get('partial')!r})"

    def figures(self) -> dict[str, Any]:
        """The report's figures drawn with matplotlib: ``"traces"`` (measured, base-model and
        best-candidate drive force of the held-out recording the base model misses most) and
        ``"gap_conditions"`` (each recording's gap under both models against v_a/v_d)."""
        import matplotlib.pyplot as plt

        d = self._figure_data
        figs: dict[str, Any] = {}
        fig, ax = plt.subplots(figsize=(8, 3.5))
        tr = d.get("traces")
        if tr is not None:
            for label, y, colour in tr["series"]:
                ax.plot(tr["t"], y, lw=0.8, color=colour, label=label)
            ax.set_title(tr["title"], fontsize=9)
            ax.set_xlabel("t [s]")
            ax.set_ylabel("F_d [N]")
            ax.legend(fontsize=8)
        figs["traces"] = fig
        fig, ax = plt.subplots(figsize=(6, 4))
        g = d.get("gaps")
        if g is not None:
            ax.scatter(g["va_ratio"], g["gap_base"], label="base model", marker="o", color="tab:blue")
            ax.scatter(g["va_ratio"], g["gap_best"], label="best candidate", marker="x", color="tab:red")
            ax.axhline(1.0, color="grey", lw=0.8, ls=":")
            ax.set_xlabel("v_a / v_d")
            ax.set_ylabel("gap (1 = within noise)")
            ax.set_yscale("log")
            ax.legend(fontsize=8)
            ax.set_title(f"verdict: {self.json.get('verdict')}", fontsize=9)
        figs["gap_conditions"] = fig
        return figs


def _diagnosis_figure_data(path: str) -> dict[str, Any]:
    import h5py

    out: dict[str, Any] = {}
    if not os.path.isfile(path):
        return out
    with h5py.File(path, "r") as f:
        if "recordings" in f:
            g = f["recordings"]
            gaps = {k: g[k][()] for k in ("gap_base", "gap_best") if k in g}
            if "va_ratio" in g:
                gaps["va_ratio"] = g["va_ratio"][()]
            if len(gaps) == 3:
                out["gaps"] = gaps
        if "figure_traces" in f:
            g = f["figure_traces"]
            colours = {"measured": "0.6", "base": "tab:blue", "best": "tab:red"}
            series = []
            for key in ("measured", "base", "best"):
                if key in g:
                    label = g[key].attrs.get("long_name", key)
                    label = label.decode() if isinstance(label, bytes) else str(label)
                    series.append((label, g[key][()], colours[key]))
            title = g.attrs.get("title", "")
            out["traces"] = {
                "t": g["t"][()],
                "series": series,
                "title": title.decode() if isinstance(title, bytes) else str(title),
            }
    return out


def diagnose(
    campaign: Union[Campaign, PathLike],
    out: Optional[PathLike] = None,
    candidates: Optional[Sequence[str]] = None,
    max_iter: int = 12,
    rank_always: bool = False,
    skip_implausible: bool = False,
    plots: bool = True,
    limits: bool = True,
) -> Diagnosis:
    """Where the model departs from a campaign, which effect explains it, and how far the gap
    shrinks on held-out recordings, as ``stickslip diagnose``.

    ``out`` is the folder for ``diagnosis.json``, ``diagnosis.h5`` and the PNG figures
    (default: a temporary folder, removed once the results are read); ``plots=False`` skips
    the PNG files (the matplotlib figures of :meth:`Diagnosis.figures` remain);
    ``limits=False`` skips the detection limits (``d.limits``: what the campaign could not have
    seen, computed where the model in hand leaves no gap).
    """
    tmp: Optional[tempfile.TemporaryDirectory[str]] = None
    if out is None:
        tmp = tempfile.TemporaryDirectory(prefix="stickslip-diagnosis-")
        target = os.path.join(tmp.name, "diagnosis")
    else:
        target = os.fspath(out)
    args = [_campaign_dir(campaign), "--out", target, "--max-iter", str(max_iter)]
    if candidates:
        args += ["--candidates", ",".join(candidates)]
    if rank_always:
        args.append("--rank-always")
    if skip_implausible:
        args.append("--skip-implausible")
    if not limits:
        args.append("--no-limits")
    if not plots or tmp is not None:
        args.append("--no-plots")
    try:
        text, summary, folder, written = _native.diagnose(args)
        d = Diagnosis(json.loads(text), summary, folder, written)
        if tmp is not None:
            d.out, d.files = "", []
        return d
    finally:
        if tmp is not None:
            tmp.cleanup()


class Plan(_Report):
    """A plan of recordings from ``stickslip plan``: the JSON's fields as attributes
    (``rivals``, ``open_pairs``, ``recordings`` (each with its ``conditions``, ``duration``,
    ``rate``, ``discrimination``, ``features`` and ``why``), ``outcomes``, ``space``, ...),
    :meth:`to_dict`, the printed summary as ``summary``, the files written as ``files``, and the
    planned recordings as :meth:`recordings_table` and the expected evidence as
    :meth:`outcomes_table` (both :class:`xarray.Dataset`)."""

    def __init__(self, data: dict[str, Any], summary: str, written: Sequence[str]) -> None:
        self.json = data
        self.summary = summary
        self.files = list(written)

    def __repr__(self) -> str:
        j = self.json
        names = [r["name"] for r in j.get("recordings", [])]
        return f"Plan(rivals={[r['name'] for r in j.get('rivals', [])]!r}, recordings={names!r})"

    def recordings_table(self) -> xr.Dataset:
        """The planned recordings along a ``recording`` dimension (their names): conditions
        (``v_d`` [m/s], ``k_d`` [N/m], ``f`` [Hz], ``u0`` [m], ``va_ratio``, ``t_on`` [s]),
        ``duration`` [s], ``rate`` [Hz] and ``order``."""
        recs = self.json.get("recordings", [])
        names = [r["name"] for r in recs]
        units = {"v_d": "m/s", "k_d": "N/m", "f": "Hz", "u0": "m", "va_ratio": "1", "t_on": "s"}
        data: dict[str, Any] = {
            k: ("recording", np.array([r["conditions"][k] for r in recs], float), {"units": u})
            for k, u in units.items()
        }
        data["duration"] = ("recording", np.array([r["duration"] for r in recs], float), {"units": "s"})
        data["rate"] = ("recording", np.array([r["rate"] for r in recs], float), {"units": "Hz"})
        data["order"] = ("recording", np.array([r["order"] for r in recs], int), {})
        return xr.Dataset(data, coords={"recording": names})

    def outcomes_table(self) -> xr.Dataset:
        """Ln odds [nats] for each rival as the ``truth`` against each ``other``: ``now`` (the
        diagnosis's held-out evidence), ``expected`` (the criterion) and ``simulated`` (the
        plan's check by simulation; NaN where not checked)."""
        rivals = [r["name"] for r in self.json.get("rivals", [])]
        n = len(rivals)
        cols = {"now": "ln_odds_now", "expected": "ln_odds_expected", "simulated": "ln_odds_simulated"}
        arrays = {k: np.full((n, n), np.nan) for k in cols}
        for o in self.json.get("outcomes", []):
            i, j = rivals.index(o["truth"]), rivals.index(o["other"])
            for k, key in cols.items():
                v = o.get(key)
                arrays[k][i, j] = np.nan if v is None else v
        data = {k: (("truth", "other"), a, {"units": "nats"}) for k, a in arrays.items()}
        return xr.Dataset(data, coords={"truth": rivals, "other": rivals})


def plan(
    campaign: Union[Campaign, PathLike],
    n: int = 6,
    space: Optional[PathLike] = None,
    out: Optional[PathLike] = None,
    diagnosis: Optional[PathLike] = None,
    check: bool = True,
    random: bool = False,
    seed: int = 1,
    plots: bool = True,
) -> Plan:
    """The ``n`` recordings that best tell apart the explanations a campaign's diagnosis leaves
    standing, within the design space (the campaign's own ranges, or the TOML file ``space``),
    as ``stickslip plan``. It reuses the campaign's ``diagnosis.json`` (``diagnosis``, else
    ``results/diagnose-NAME/`` or ``out``) where it is of the same recordings and version, and
    diagnoses first otherwise. ``out`` receives one conditions file per planned recording,
    ``plan.json`` and ``plan.png`` (default ``results/plan-NAME``); ``check=False`` skips the
    check by simulation; ``random=True`` draws the recordings at random (the baseline).
    """
    args = [_campaign_dir(campaign), "--recordings", str(n), "--seed", str(seed)]
    if space is not None:
        args += ["--space", os.fspath(space)]
    if out is not None:
        args += ["--out", os.fspath(out)]
    if diagnosis is not None:
        args += ["--diagnosis", os.fspath(diagnosis)]
    if not check:
        args.append("--no-check")
    if random:
        args.append("--random")
    if not plots:
        args.append("--no-plots")
    text, summary, written = _native.plan(args)
    return Plan(json.loads(text), summary, written)
