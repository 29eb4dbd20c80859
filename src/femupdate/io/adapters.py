"""Identification results of modal-analysis libraries as femupdate test data.

Two libraries that engineers run before updating a model:

* **pyOMA2** (operational modal analysis: SSI, FDD, EFDD, FSDD, pLSCF, their multi-setup forms
  and clustering): a result object has ``Fn`` (natural frequencies, Hz), ``Phi`` (shapes,
  channels × modes, complex, each scaled to 1 at its largest entry), and, where the method
  gives them, ``Xi`` (damping ratios) and the standard deviations ``Fn_std`` (Hz), ``Xi_std``
  and ``Phi_std`` (per shape entry, in the shape's own scaling) -- SSI with ``calc_unc=True``
  propagates them from the data, a multi-setup merge gives them between setups.
* **sdypy-EMA** (experimental modal analysis from FRFs: LSCF poles, LSFD modal constants): a
  ``Model`` has ``nat_freq`` (Hz) and ``nat_xi`` after the poles are selected, and the modal
  constants ``A`` (locations × modes, complex) after ``get_constants``; with a driving point,
  ``phi`` (the constants scaled to shapes).

:func:`from_pyoma2` and :func:`from_sdypy_ema` take the library's object itself (read by its
attribute names: neither library is imported here); :func:`read_identification` reads the same
arrays saved with NumPy (``numpy.savez``, the library's attribute names as the keys, the channel
map as ``channels``), the file route of the command line (``femupdate convert-data``, and every
command that reads test data takes a ``.npz`` file).  Nothing is unpickled.

The **channel map** says which femupdate dof each channel (row of the shapes) measures, with the
sensor's sign: one entry per channel in the library's channel order (``"3:x"``, ``"-3:x"`` for a
sensor pointing along -x, ``""`` or None for a channel to leave out), or a mapping from channel
(0-based index as in the library's arrays, or a name of ``channel_names``) to its dof.  Channels
left out of a mapping are left out of the data, with a note.

Standard deviations become those of :class:`~femupdate.testdata.MeasuredMode`, which updating
turns into weights and the covariance: ``std_frequency = Fn_std / Fn`` (relative; kept as
``std_eigenvalue = 2 Fn_std / Fn``), ``std_damping_ratio = Xi_std``, and ``std_shape`` = the RMS of
``Phi_std`` over the mapped channels divided by the norm of the mapped shape -- the standard
deviation of the entries of the unit-length shape that updating compares by default (``--shape-
scaling unit``), to first order.  A mode whose standard deviation is missing, zero, negative or
not finite gets none, with a note.  Every array must hold numbers (text, booleans and objects are
refused naming the key); only shapes, modal constants and ``Phi_std`` may be complex.
"""

from __future__ import annotations

import math
from collections.abc import Mapping, Sequence
from pathlib import Path

import numpy as np

from .._errors import InputError
from ..dofs import describe, resolve_dof
from ..testdata import MeasuredMode, TestData

#: the arrays of a saved pyOMA2 result (numpy.savez keys = the result's attribute names)
PYOMA2_KEYS = ("Fn", "Phi", "Xi", "Fn_std", "Xi_std", "Phi_std")
#: the arrays of a saved sdypy-EMA model
SDYPY_EMA_KEYS = ("nat_freq", "nat_xi", "phi", "A")


def channel_map(channels, n_channels: int, channel_names: Sequence[str] | None = None,
                dofs: Sequence[str] | None = None, what: str = "channels") -> list[tuple[int, str, float]]:
    """The mapped channels as ``(index, dof label, sign)``, in channel order.

    Parameters
    ----------
    channels : sequence or mapping
        One entry per channel (``"3:x"``, ``"-3:x"``, ``"#N"`` with ``dofs``, or ``""``/None to
        leave the channel out), or a mapping {channel: dof} whose keys are 0-based channel
        indices or names in ``channel_names``.
    n_channels : int
        The number of channels (rows of the shapes).
    channel_names : sequence of str, optional
        Names of the channels, in order, for a mapping keyed by name.
    dofs : sequence of str, optional
        The model's dof list that ``"#N"`` counts in.
    what : str, default ``"channels"``
        How the messages name the map.

    Returns
    -------
    list of (int, str, float)
        Channel index, canonical dof label and sign (1.0 or -1.0).

    Raises
    ------
    InputError
        A sequence of another length than the channels; a key that is no channel; a malformed
        dof or one with two signs; two channels on one dof; no channel mapped.
    """
    names = None if channel_names is None else [str(n) for n in channel_names]
    if names is not None and len(names) != n_channels:
        raise InputError(f"channel_names: {len(names)} names for {n_channels} channels")
    entries: list[tuple[int, object]] = []
    if isinstance(channels, Mapping):
        for key, value in channels.items():
            if isinstance(key, (int, np.integer)) and not isinstance(key, bool):
                if not 0 <= int(key) < n_channels:
                    raise InputError(f"{what}: channel {key} is out of range (0-based indices 0..{n_channels - 1})")
                entries.append((int(key), value))
            elif isinstance(key, str) and names is not None and key in names:
                entries.append((names.index(key), value))
            else:
                known = f"names {', '.join(names[:8])}" if names else "no channel names given"
                raise InputError(f"{what}: {key!r} is neither a 0-based channel index nor a channel name ({known})")
        entries.sort()
    else:
        if isinstance(channels, str) or not isinstance(channels, Sequence | np.ndarray):
            raise InputError(f"{what}: expected one dof per channel (a list) or a mapping {{channel: dof}}, "
                             f"got {channels!r}")
        items = list(channels)
        if len(items) != n_channels:
            raise InputError(f"{what}: {len(items)} entries for {n_channels} channels (one per channel in the "
                             "library's order; an empty entry leaves a channel out)")
        entries = list(enumerate(items))
    out: list[tuple[int, str, float]] = []
    seen: dict[str, int] = {}
    for k, value in entries:
        if value is None or (isinstance(value, str) and not value.strip()):
            continue
        if not isinstance(value, str):
            raise InputError(f"{what}: channel {k}: expected a dof label such as \"3:x\" or \"-3:x\", got {value!r}")
        text = value.strip()
        sign = -1.0 if text.startswith("-") else 1.0
        if text[:1] in ("+", "-"):
            text = text[1:].strip()
        if not text or text[:1] in ("+", "-"):
            raise InputError(f"{what}: channel {k}: {value!r} is not a dof label with at most one sign, such as "
                             "\"3:x\" or \"-3:x\"")
        try:
            label = resolve_dof(text, dofs, f"{what}: channel {k}")
        except InputError as exc:
            msg = str(exc)
            raise InputError(msg if msg.startswith(what) else f"{what}: channel {k}: {msg}") from None
        if label in seen:
            raise InputError(f"{what}: channels {seen[label]} and {k} both measure {label}")
        seen[label] = k
        out.append((k, label, sign))
    if not out:
        raise InputError(f"{what}: no channel is mapped to a dof")
    return out


def _numbers(values, what: str, complex_ok: bool = False) -> np.ndarray | None:
    """``values`` as an array of numbers (None if absent): real (float), or complex where
    ``complex_ok``; strings, booleans, objects and ragged nestings refused naming ``what``.

    A complex array whose imaginary parts are all zero is taken as real.
    """
    if values is None:
        return None
    try:
        arr = np.asarray(values)
    except (ValueError, TypeError) as exc:  # ragged nestings of lists
        raise InputError(f"{what}: not an array of numbers ({exc})") from None
    kind = arr.dtype.kind
    if arr.size == 0:
        return np.zeros(arr.shape)
    if kind == "b":
        raise InputError(f"{what}: booleans (True/False), not numbers")
    if kind == "c":
        if not complex_ok and np.any(arr.imag):
            raise InputError(f"{what}: complex values; expected real numbers")
        return arr if complex_ok else arr.real.astype(float)
    if kind not in "iuf":
        got = {"U": "text", "S": "bytes", "O": "Python objects"}.get(kind, str(arr.dtype))
        first = ", ".join(repr(v) for v in arr.ravel()[:3].tolist())
        raise InputError(f"{what}: expected numbers, got {got} ({first}{', ...' if arr.size > 3 else ''})")
    return arr.astype(float)


def _per_mode(values, n: int, what: str) -> np.ndarray | None:
    """An optional per-mode array of real numbers (None if absent), checked for length."""
    arr = _numbers(values, what)
    if arr is None or arr.size == 0:
        return None
    arr = arr.ravel()
    if arr.size != n:
        raise InputError(f"{what}: {arr.size} values for {n} modes")
    return arr


def modal_test_data(frequency_hz, shapes, channels, *, damping_ratio=None, frequency_std_hz=None,
                    damping_ratio_std=None, shape_std=None, channel_names=None, dofs=None,
                    source: str = "identification", what: str = "channels") -> TestData:
    """Test data from identified modal arrays and a channel map (the core of the adapters).

    Parameters
    ----------
    frequency_hz : array_like, shape ``(n_modes,)``
        Natural frequencies, Hz.
    shapes : array_like, shape ``(n_channels, n_modes)``
        Shapes (or modal constants), real or complex, in any scaling; None or empty for no shapes.
    channels : sequence or mapping
        The channel map (:func:`channel_map`).
    damping_ratio, frequency_std_hz, damping_ratio_std : array_like, shape ``(n_modes,)``, optional
        Damping ratios ζ, standard deviations of the frequencies (Hz) and of ζ.
    shape_std : array_like, shape ``(n_channels, n_modes)``, optional
        Standard deviation of each shape entry, in the scaling of ``shapes``.
    channel_names, dofs
        As :func:`channel_map`.
    source : str
        What the data came from, for the notes and mode labels.
    what : str
        How the messages name the channel map.

    Returns
    -------
    TestData
        One mode per frequency, in the given order (labels ``"<source> mode k"``), shaped at the
        mapped channels' dofs with the sensors' signs applied; notes name what was left out.

    Raises
    ------
    InputError
        Arrays of inconsistent sizes or that are not numbers (complex frequencies or damping
        ratios included); non-finite frequencies or shapes; and as :func:`channel_map` and
        :class:`~femupdate.testdata.MeasuredMode`.
    """
    f = _numbers(frequency_hz, f"{source}: frequencies")
    f = np.zeros(0) if f is None else f.ravel()
    n = f.size
    if n == 0:
        raise InputError(f"{source}: no identified modes")
    if not np.all(np.isfinite(f)):
        bad = [str(k + 1) for k in np.flatnonzero(~np.isfinite(f))]
        raise InputError(f"{source}: frequency of mode(s) {', '.join(bad)} is not finite (a pole that was not found?)")
    notes: list[str] = []
    phi = _numbers(shapes, f"{source}: shapes", complex_ok=True)
    if phi is not None and phi.size == 0:
        phi = None
    mapped: list[tuple[int, str, float]] = []
    if phi is not None:
        if phi.ndim == 1:
            phi = phi.reshape(-1, 1) if n == 1 else phi.reshape(1, -1)
        if phi.ndim != 2 or phi.shape[1] != n:
            raise InputError(f"{source}: shapes of shape {phi.shape}, expected (channels, {n} modes)")
        mapped = channel_map(channels, phi.shape[0], channel_names, dofs, what)
        left = [str(k) for k in range(phi.shape[0]) if k not in {c for c, _, _ in mapped}]
        if left:
            notes.append(f"{source}: channel(s) {', '.join(left)} (0-based) not in the channel map, left out")
    zeta = _per_mode(damping_ratio, n, f"{source}: damping ratios")
    f_std = _per_mode(frequency_std_hz, n, f"{source}: frequency standard deviations")
    z_std = _per_mode(damping_ratio_std, n, f"{source}: damping-ratio standard deviations")
    p_std = None
    p_given = _numbers(shape_std, f"{source}: shape standard deviations", complex_ok=True)
    if p_given is not None and phi is not None and p_given.size:
        p_std = np.abs(p_given) if np.iscomplexobj(p_given) else p_given  # a real one below 0 is no std
        if p_std.shape != phi.shape:
            raise InputError(f"{source}: shape standard deviations of shape {p_std.shape}, expected {phi.shape}")
    rows = [c for c, _, _ in mapped]
    labels = tuple(lab for _, lab, _ in mapped)
    signs = np.array([s for _, _, s in mapped])
    missing: dict[str, list[int]] = {}
    modes = []
    for k in range(n):
        extra: dict = {}
        shape = np.zeros(0)
        if phi is not None:
            shape = phi[rows, k] * signs
            if np.iscomplexobj(shape) and not np.any(shape.imag):
                shape = shape.real
            if not np.all(np.isfinite(shape)):
                raise InputError(f"{source}: the shape of mode {k + 1} is not finite at the mapped channels")
        if zeta is not None:
            if math.isfinite(zeta[k]) and 0 <= zeta[k] < 1:
                extra["damping_ratio"] = float(zeta[k])
                if z_std is not None and math.isfinite(z_std[k]) and z_std[k] > 0:
                    extra["std_damping_ratio"] = float(z_std[k])
                elif z_std is not None:
                    missing.setdefault("damping-ratio", []).append(k + 1)
            else:
                notes.append(f"{source}: mode {k + 1}: damping ratio {zeta[k]:g} is not in [0, 1); left out")
        if f_std is not None:
            if math.isfinite(f_std[k]) and f_std[k] > 0 and f[k] > 0:
                extra["std_frequency"] = float(f_std[k] / f[k])
            else:
                missing.setdefault("frequency", []).append(k + 1)
        if p_std is not None and shape.size >= 2:
            s = p_std[rows, k]
            norm = float(np.linalg.norm(shape))
            if np.all(np.isfinite(s)) and np.all(s >= 0) and np.any(s > 0) and norm > 0:
                top = float(s.max())  # the RMS scaled by the largest entry: no overflow of the squares
                extra["std_shape"] = top * float(np.sqrt(np.mean((s / top) ** 2))) / norm
            else:
                missing.setdefault("shape", []).append(k + 1)
        modes.append(MeasuredMode.from_frequency(float(f[k]), labels if shape.size else (), shape,
                                                 f"{source} mode {k + 1}", **extra))
    for kind, which in missing.items():
        notes.append(f"{source}: no finite positive {kind} standard deviation for mode(s) {', '.join(map(str, which))}; "
                     "those modes carry none")
    if p_std is not None:
        notes.append(f"{source}: std_shape is the RMS of the shape entries' standard deviations over the mapped "
                     "channels, scaled to the unit-length shape (updating's default --shape-scaling unit)")
    if mapped and any(s < 0 for s in signs):
        neg = [lab for _, lab, s in mapped if s < 0]
        notes.append(f"{source}: sensor sign -1 applied at {describe(neg)}")
    return TestData(modes=tuple(modes), notes=tuple(notes))


#: the arrays that may be complex (shapes, modal constants, their standard deviations)
_COMPLEX_KEYS = frozenset({"Phi", "Phi_std", "phi", "A"})


def _arrays(get, keys, source: str) -> dict[str, np.ndarray | None]:
    """The library's arrays ``get(key)`` for ``keys``, each checked to hold numbers (messages
    name the key as the library names it)."""
    return {k: _numbers(get(k), f"{source}: {k}", complex_ok=k in _COMPLEX_KEYS) for k in keys}


def from_pyoma2(result, channels, *, channel_names: Sequence[str] | None = None, dofs: Sequence[str] | None = None,
                source: str = "pyOMA2") -> TestData:
    """Test data from a pyOMA2 result: natural frequencies, (complex) shapes, damping ratios and
    the standard deviations of the methods that give them.

    Parameters
    ----------
    result : pyOMA2 result or algorithm
        A result object after modal parameter extraction (``mpe``): ``SSIResult``,
        ``FDDResult``, ``EFDDResult``, ``pLSCFResult``, ``MsPoserResult``, ``ClusteringResult``
        -- anything with ``Fn`` and ``Phi`` -- or the algorithm that holds it (its ``result``).
    channels : sequence or mapping
        The channel map (:func:`channel_map`): which dof each channel of ``Phi`` measures.
    channel_names, dofs
        As :func:`channel_map`.
    source : str, default ``"pyOMA2"``
        Name in the notes and mode labels.

    Returns
    -------
    TestData
        ``Fn`` as the frequencies, ``Phi`` at the mapped dofs, ``Xi`` as ``damping_ratio``;
        ``Fn_std``, ``Xi_std`` and ``Phi_std`` (SSI with ``calc_unc=True``; between setups for a
        multi-setup merge) as the modes' standard deviations (see the module's notes).

    Raises
    ------
    InputError
        An object with neither ``Fn`` nor ``result``; no ``Fn`` (modal parameters not extracted:
        run ``mpe`` first); arrays that are not numbers (named by attribute); and as
        :func:`modal_test_data`.
    """
    if not hasattr(result, "Fn") and not hasattr(result, "result"):
        raise InputError(f"{source}: expected a pyOMA2 result (an object with Fn and Phi) or the algorithm that holds "
                         f"it, got {type(result).__name__}")
    res = getattr(result, "result", None) if not hasattr(result, "Fn") else result
    if res is None or getattr(res, "Fn", None) is None:
        raise InputError(f"{source}: the result has no natural frequencies (Fn): extract the modes first "
                         "(setup.mpe(name, sel_freq=...))")
    a = _arrays(lambda k: getattr(res, k, None), PYOMA2_KEYS, source)
    return modal_test_data(a["Fn"], a["Phi"], channels, damping_ratio=a["Xi"], frequency_std_hz=a["Fn_std"],
                           damping_ratio_std=a["Xi_std"], shape_std=a["Phi_std"], channel_names=channel_names,
                           dofs=dofs, source=source)


def from_sdypy_ema(model, channels, *, channel_names: Sequence[str] | None = None, dofs: Sequence[str] | None = None,
                   source: str = "sdypy-EMA") -> TestData:
    """Test data from an sdypy-EMA ``Model``: natural frequencies, damping ratios and the
    shapes from the modal constants.

    Parameters
    ----------
    model : sdypy.EMA.Model
        After pole selection (``select_poles`` / ``select_closest_poles``: ``nat_freq``,
        ``nat_xi``) and, for shapes, ``get_constants`` (``A``; ``phi`` when the model has a
        driving point).
    channels : sequence or mapping
        The channel map (:func:`channel_map`): which dof each FRF location (row of ``A``)
        measures.
    channel_names, dofs
        As :func:`channel_map`.
    source : str, default ``"sdypy-EMA"``
        Name in the notes and mode labels.

    Returns
    -------
    TestData
        ``nat_freq`` as the frequencies, ``nat_xi`` as ``damping_ratio``, and ``phi`` (else the
        modal constants ``A``, proportional to the shapes for one reference) at the mapped dofs;
        no standard deviations (the library gives none).

    Raises
    ------
    InputError
        An object with neither ``nat_freq`` nor ``frf``; no ``nat_freq`` (poles not selected);
        arrays that are not numbers (named by attribute); and as :func:`modal_test_data`.
    """
    if not hasattr(model, "nat_freq") and not hasattr(model, "frf"):
        raise InputError(f"{source}: expected an sdypy-EMA Model (an object with nat_freq after pole selection), got "
                         f"{type(model).__name__}")
    a = _arrays(lambda k: getattr(model, k, None), SDYPY_EMA_KEYS, source)
    freq = a["nat_freq"]
    if freq is None:
        raise InputError(f"{source}: the model has no natural frequencies (nat_freq): select the poles first "
                         "(select_closest_poles or select_poles)")
    shapes = a["phi"] if a["phi"] is not None else a["A"]
    data = modal_test_data(freq, shapes, channels, damping_ratio=a["nat_xi"], channel_names=channel_names,
                           dofs=dofs, source=source)
    if shapes is None:
        return TestData(modes=data.modes, notes=(*data.notes, f"{source}: no modal constants (run get_constants "
                                                               "for shapes): frequencies and damping only"))
    return data


def read_identification(path, dofs: Sequence[str] | None = None, channels=None) -> TestData:
    """Test data from an identification result saved with ``numpy.savez``.

    Parameters
    ----------
    path : str or os.PathLike
        A ``.npz`` file holding a pyOMA2 result's arrays (keys ``Fn``, ``Phi`` and optionally
        ``Xi``, ``Fn_std``, ``Xi_std``, ``Phi_std``) or an sdypy-EMA model's (``nat_freq`` and
        optionally ``nat_xi``, ``phi`` or ``A``), and the channel map ``channels`` (strings, one
        per channel: ``"3:x"``, ``"-3:x"``, ``""`` to leave a channel out).
    dofs : sequence of str, optional
        The model's dof list that ``"#N"`` counts in.
    channels : sequence or mapping, optional
        A channel map that replaces the file's (:func:`channel_map`).

    Returns
    -------
    TestData

    Raises
    ------
    InputError
        A missing or unreadable file, or one that is no zip archive of arrays (a ``.npy`` file,
        text); object arrays (the file is read without unpickling); keys of neither library; no
        channel map (errors in the file's own map name the file); arrays that are not numbers
        (named by key); and as :func:`modal_test_data`.
    """
    path = Path(path)
    try:
        with open(path, "rb") as fh:
            head = fh.read(6)
    except FileNotFoundError:
        raise InputError(f"{path}: no such file") from None
    except IsADirectoryError:
        raise InputError(f"{path}: is a folder, not a .npz file") from None
    if not head.startswith(b"PK"):  # numpy.savez writes a zip archive; np.load would try to unpickle the rest
        what = ("one array saved with numpy.save (.npy)" if head.startswith(b"\x93NUMPY")
                else "an empty file" if not head else "not a zip archive")
        raise InputError(f"{path}: not a .npz file of arrays ({what}); save the result with numpy.savez")
    try:
        with np.load(path, allow_pickle=False) as z:
            arrays = {k: z[k] for k in z.files}
    except ValueError as exc:
        if "pickle" not in str(exc) and "Object arrays" not in str(exc):  # not numpy's refusal to unpickle
            raise InputError(f"{path}: not a readable .npz file ({exc})") from None
        raise InputError(f"{path}: holds an array of Python objects, which femupdate does not unpickle; save "
                         f"plain numeric and string arrays ({exc})") from None
    except Exception as exc:  # a damaged or non-zip file  # noqa: BLE001
        raise InputError(f"{path}: not a readable .npz file ({type(exc).__name__}: {exc})") from None
    map_in_file = channels is None
    if channels is None:
        if "channels" not in arrays:
            raise InputError(f"{path}: no 'channels' array: save the channel map with the result "
                             "(numpy.savez(..., channels=[\"1:x\", \"-2:x\", ...]), one dof per channel), or give "
                             "it (convert-data --channels)")
        ch = arrays["channels"]
        if ch.dtype.kind not in "US":
            raise InputError(f"{path}: 'channels' must be strings (one dof label per channel), got {ch.dtype}")
        channels = [str(c) for c in ch.ravel()]
    names = None
    if "channel_names" in arrays:
        names = [str(c) for c in arrays["channel_names"].ravel()]
    name = path.name
    if "Fn" in arrays:
        unknown = sorted(set(arrays) - {*PYOMA2_KEYS, "channels", "channel_names"})
    elif "nat_freq" in arrays:
        unknown = sorted(set(arrays) - {*SDYPY_EMA_KEYS, "channels", "channel_names"})
    else:
        raise InputError(f"{path}: neither a pyOMA2 result (keys Fn, Phi, Xi, Fn_std, Xi_std, Phi_std) nor an "
                         f"sdypy-EMA model (keys nat_freq, nat_xi, phi or A); the file has {', '.join(arrays) or 'none'}")
    try:
        if "Fn" in arrays:
            a = _arrays(arrays.get, PYOMA2_KEYS, name)
            data = modal_test_data(a["Fn"], a["Phi"], channels, damping_ratio=a["Xi"], frequency_std_hz=a["Fn_std"],
                                   damping_ratio_std=a["Xi_std"], shape_std=a["Phi_std"], channel_names=names,
                                   dofs=dofs, source=f"{name} (pyOMA2)")
        else:
            a = _arrays(arrays.get, SDYPY_EMA_KEYS, name)
            shapes = a["phi"] if a["phi"] is not None else a["A"]
            data = modal_test_data(a["nat_freq"], shapes, channels, damping_ratio=a["nat_xi"], channel_names=names,
                                   dofs=dofs, source=f"{name} (sdypy-EMA)")
    except InputError as exc:  # the file's own channel map (and names) are named with the file
        msg = str(exc)
        if msg.startswith("channel_names:") or (map_in_file and msg.startswith("channels:")):
            raise InputError(f"{path}: {msg}") from None
        raise
    if unknown:
        return TestData(modes=data.modes, notes=(*data.notes, f"{name}: array(s) not read: {', '.join(unknown)}"))
    return data


__all__ = ["channel_map", "modal_test_data", "from_pyoma2", "from_sdypy_ema", "read_identification",
           "PYOMA2_KEYS", "SDYPY_EMA_KEYS"]
