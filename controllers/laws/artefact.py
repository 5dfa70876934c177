"""A law as one file of plain data (the ``rig-law`` artefact): a single JSON document, never pickle.

Every law of :mod:`controllers.laws` -- the model-based laws' designed tables and the trained
policies alike -- reaches a file, the real-time loop and back through this one format: one file,
one SHA-256, an optional HMAC.  This module is the codec (canonical JSON, base64 arrays, checksum,
signature, validation, load / save); it imports only the standard library, numpy and
:mod:`controllers.laws.base`, so the law runtimes may use it (an RL law reads its shipped policy
file with it).

Why one JSON file and not ``.npz`` + manifest: one file cannot lose its manifest; JSON has no code
path (``json.loads`` builds dicts, lists, strings and numbers only), whereas ``.npz`` is a zip archive
with its own parser surface (and ``np.load`` is only safe with ``allow_pickle=False``, a flag someone
can forget); the checksum covers header and arrays in one canonical byte string; the header stays
human-readable.  The size cost (base64: 4/3 of the raw bytes) is ~60 kB for a 64x64 MLP.

| key | type | meaning |
|---|---|---|
| ``format`` | ``"rig-law"`` | file type |
| ``format_version`` | int | :data:`FORMAT_VERSION`; another version is refused |
| ``kind`` | str | the law's ``artefact_kind`` (table below) |
| ``spec`` | object | the :class:`controllers.laws.base.LoopSpec` the law was designed for |
| ``sensors`` | object | sensor layout it was designed with: ``rate_filter_hz``, ``link_delay_steps``, ``quantise``, ``pot_bits``, ``encoder_bits`` |
| ``limits`` | object | ``position_deg``, ``rate_deg_s``: per action, output limits the loop always applies |
| ``params`` | object | the kind's scalar / string / object parameters |
| ``arrays`` | object | name -> ``{"dtype": "<f8" or "<i8", "shape": [...], "data": base64 of the little-endian bytes}`` |
| ``provenance`` | object | created (UTC), tool, git commit, host, python / numpy versions, source, notes; a trained policy: the training record |
| ``sha256`` | hex str | SHA-256 of the canonical JSON of every key above |
| ``signature`` | object, optional | ``{"alg": "HMAC-SHA256", "value": hex}`` over the same bytes with a shared key |

Canonical JSON: ``json.dumps(body, sort_keys=True, separators=(",", ":"), ensure_ascii=True,
allow_nan=False)`` encoded as ASCII.  Every array must be finite.

Kinds: the law registry is the kind registry.  A law class registered with
:func:`controllers.laws.base.register` names its file kind by its class attribute ``artefact_kind``
and converts itself with ``law.to_data()`` (numpy arrays go to ``arrays``, JSON values to ``params``)
and ``cls.from_data(data, spec, num_envs=1)`` (the same dict back; a ValueError names what it
refuses).  :func:`artefact_class` finds the class of a kind among :data:`controllers.laws.LAWS`.

| kind | class | arrays | params |
|---|---|---|---|
| ``linear`` | :class:`~controllers.laws.linear.LinearLaw` (or any static law with ``linear_form()``) | ``K``, ``obs0``, ``u0``, ``rate_limit`` | -- |
| ``pid`` | :class:`~controllers.laws.pid.PIDLaw` | ``kp``, ``ki``, ``k_angle``, ``rate_demand_max``; ``phi_grid``, ``trim_roll``; ``sig_*`` | ``axes``, ``v_design``, ``rate_limit``, ``feedforward``, ``b_roll``, ``damp_roll``, ``sig_*``, ``design`` |
| ``lqr`` | :class:`~controllers.laws.lqr.LQRLaw` | ``airspeeds``, ``phis``; ``K``, ``u_trim``, ``q_op``, ``A_q``, ``A_w``, ``B`` over (V, phi); ``kalman_gain``; ``sig_*`` | ``phi_step``, ``link_delay_steps``, ``estimator``, ``sig_*``, ``design`` |
| ``pid_heave_sway`` | :class:`~controllers.laws.heave_sway.HeaveSwayPID` | model over V: ``airspeeds``, ``cw``, ``b``, ``A_row``, ``q_op``, ``S``, ``static_theta``, ``static_u``, ``static_n``; ``sig_*`` | ``kp``, ``ki``, ``k_angle``, ``v_design``, ``rate_limit``, ``feedforward``, ``decouple``, ``ref_*``, ``sig_*``, ``design`` |
| ``lqr_heave_sway`` | :class:`~controllers.laws.heave_sway.HeaveSwayLQR` | the same model; ``K``, ``A_q``, ``A_w``, ``B`` over V; ``kalman_gain``; ``sig_*`` | ``link_delay_steps``, ``ref_*``, ``sig_*``, ``design`` |
| ``lqr_emulation`` | :class:`~controllers.laws.emulation.EmulationLQR` | ``airspeeds``, ``K``, ``q_op``; servo models; ``ref_scales``; ``sig_*`` | ``hawk_delay_steps``, ``arm_length``, ``sig_*``, ``design`` |
| ``ppo``, ``sac`` | :class:`~controllers.laws.rl.PPOPolicy`, :class:`~controllers.laws.rl.SACPolicy` | ``weight_<i>`` (out, in), ``bias_<i>`` (out,) per layer; ``obs_mean``, ``obs_var`` (VecNormalize); ``action_low``, ``action_high`` | ``activation``, ``postprocess``, ``obs_norm`` (``clip_obs``, ``epsilon``, or null) |

A trained policy is written in this format by training itself (``rig train`` writes ``policy.json``,
with the training record as ``provenance``: command, hyperparameters, curve, final evaluation,
versions, the environment settings ``env_overrides``).  A law re-exported from an artefact (e.g.
``rig-deploy export --controller ppo``) records the file it came from as ``provenance.derived_from``
(its ``sha256`` and ``provenance``).  A file of the earlier separate policy format
(``"format": "rig_env.rl_policy"``) is refused with the command that converts it
(``rig-deploy convert-policy OLD NEW``, :mod:`controllers.deploy.convert`).
"""

from __future__ import annotations

import base64
import errno
import hashlib
import hmac
import json
import math
import os
import platform
import re
import socket
import stat
import subprocess
from dataclasses import asdict, dataclass
from datetime import datetime, timezone
from pathlib import Path
from typing import Any, Mapping

import numpy as np

from controllers.laws.base import AERO_MODELS, LAWS, Controller, LoopSpec

__all__ = ["DEFAULT_SENSORS", "FORMAT", "FORMAT_VERSION", "OLD_POLICY_FORMAT", "Artefact", "ArtefactError", "artefact_class",
           "artefact_kinds", "canonical", "default_limits", "from_controller", "load", "provenance", "save", "sensors_of"]

FORMAT = "rig-law"
FORMAT_VERSION = 1
OLD_POLICY_FORMAT = "rig_env.rl_policy"
"""The format of the earlier separate policy files, refused by :func:`load` with the conversion command."""
MAX_BYTES = 64 * 2**20  # refuse files above 64 MiB before parsing
MAX_DEPTH = 32
"""Deepest nesting of JSON objects / arrays accepted (a law's file nests 5-8 deep), checked before parsing."""
MAX_INT_DIGITS = 18
"""Longest JSON integer accepted, digits (|n| < 10**18 fits an int64); a longer one is refused while parsing."""
_HEX64 = re.compile(r"[0-9a-f]{64}")
_DTYPES = {"<f8": np.dtype("<f8"), "<i8": np.dtype("<i8")}
_BODY_KEYS = ("format", "format_version", "kind", "spec", "sensors", "limits", "params", "arrays", "provenance")
_SENSOR_KEYS = {"rate_filter_hz": float, "link_delay_steps": int, "quantise": bool, "pot_bits": int, "encoder_bits": int}
DEFAULT_SENSORS: dict[str, Any] = {"rate_filter_hz": 10.0, "link_delay_steps": 1, "quantise": True, "pot_bits": 12, "encoder_bits": 13}
"""The environments' default sensor layout (``rig_env.envs.RigEnvConfig``'s fields of the same names; a test
checks the copy), for files made without an environment at hand (the old-format policy conversion)."""


class ArtefactError(ValueError):
    """An artefact was refused; the message names the file (when known) and what failed."""


def artefact_class(kind: str) -> type[Controller]:
    """The registered law class whose ``artefact_kind`` is ``kind`` (ArtefactError naming the known kinds)."""
    found = _find(kind)  # the built-in laws are registered: importing any controllers module imports controllers.laws
    if found is None:
        raise ArtefactError(f"kind {kind!r}: no law registered for it; registered kinds: {sorted(artefact_kinds())}")
    return found


def artefact_kinds() -> dict[str, type[Controller]]:
    """Every registered law class by its ``artefact_kind``."""
    return {c.artefact_kind: c for classes in LAWS.values() for c in classes}


def _find(kind: str) -> type[Controller] | None:
    return artefact_kinds().get(kind)


def sensors_of(config: Any) -> dict[str, Any]:
    """The sensor layout of an environment configuration (``RigVectorEnv(...).config``), as the artefact stores it."""
    return {k: t(getattr(config, k)) for k, t in _SENSOR_KEYS.items()}


@dataclass(frozen=True)
class Artefact:
    """A loaded (validated) or to-be-saved law: everything in the file but checksum and signature."""

    kind: str
    spec: LoopSpec
    sensors: dict[str, Any]
    limits: dict[str, list[float]]
    data: dict[str, Any]
    provenance: dict[str, Any]
    sha256: str = ""

    def controller(self, num_envs: int = 1) -> Controller:
        """The numpy runtime of this law (``from_data`` of the kind's class) for ``num_envs`` environments.

        A law built from a saved file remembers it (``law.artefact_source``: sha256 and provenance), so
        that exporting it again records where it came from."""
        law = artefact_class(self.kind).from_data(self.data, self.spec, num_envs)
        if self.sha256:
            law.artefact_source = {"sha256": self.sha256, "provenance": self.provenance}
        return law


# ---------------------------------------------------------------------- building
def default_limits(spec: LoopSpec, rate_deg_s: float = 350.0) -> dict[str, list[float]]:
    """Position +-``spec.action_scale_deg`` and ``rate_deg_s`` (the servos' slew rate) per action; ArtefactError unless
    ``rate_deg_s`` is a number in (0, 5000] deg/s (the range an artefact's ``limits.rate_deg_s`` takes)."""
    if isinstance(rate_deg_s, bool) or not isinstance(rate_deg_s, (int, float)) or not 0.0 < rate_deg_s <= 5000.0:
        raise ArtefactError(f"rate_deg_s = {rate_deg_s!r}: allowed range (0, 5000] deg/s")
    n = spec.n_actions
    return {"position_deg": [float(spec.action_scale_deg)] * n, "rate_deg_s": [float(rate_deg_s)] * n}


def provenance(source: str, notes: str = "") -> dict[str, Any]:
    """Who made the file, from what, when (best effort: the git commit is "" outside a checkout)."""
    try:
        here = Path(__file__).resolve().parent
        commit = subprocess.run(["git", "rev-parse", "HEAD"], cwd=here, capture_output=True, text=True, timeout=5).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        commit = ""
    return {
        "created_utc": datetime.now(timezone.utc).isoformat(timespec="seconds"),
        "tool": "controllers", "git_commit": commit, "host": socket.gethostname(),
        "python": platform.python_version(), "numpy": np.__version__, "source": source, "notes": notes,
    }


def from_controller(ctrl: Controller, sensors: Mapping[str, Any], limits: Mapping[str, list[float]] | None = None, source: str = "",
                    notes: str = "", prov: Mapping[str, Any] | None = None) -> Artefact:
    """Capture ``ctrl`` (in-memory law) with its loop's sensor layout and output limits.

    The file kind is ``ctrl.artefact_kind``; its class converts the law (``cls.data_of(ctrl)``: the law's
    own ``to_data()``, or for kind "linear" the ``linear_form()`` of another static law).  ``prov``
    replaces the default provenance (:func:`provenance` of ``source``, ``notes``); a law loaded from a
    file adds ``derived_from`` (that file's sha256 and provenance)."""
    if not isinstance(ctrl, Controller):  # else an AttributeError on .kind
        raise ArtefactError(f"ctrl = {type(ctrl).__name__}: must be a law (a controllers.laws.Controller)")
    kind = getattr(ctrl, "artefact_kind", None) or ctrl.kind
    try:
        cls = artefact_class(kind)
    except ArtefactError:
        raise ArtefactError(f"controller kind {ctrl.kind!r} exports to artefact kind {kind!r}, which is not registered; "
                            f"registered kinds: {sorted(artefact_kinds())}") from None
    data = cls.data_of(ctrl)
    p = dict(prov) if prov is not None else provenance(source or type(ctrl).__name__, notes)
    origin = getattr(ctrl, "artefact_source", None)
    if origin is not None and "derived_from" not in p:
        p["derived_from"] = dict(origin)
    art = Artefact(kind, ctrl.spec, dict(sensors), dict(limits or default_limits(ctrl.spec)), dict(data), p)
    _check_body(_body(art), "<memory>")
    _check_law(art, "<memory>")
    return art


# ---------------------------------------------------------------------- encoding
def _encode_array(name: str, a: np.ndarray) -> dict[str, Any]:
    a = np.asarray(a)
    dt = "<i8" if np.issubdtype(a.dtype, np.integer) or a.dtype == bool else "<f8"
    b = np.ascontiguousarray(a, dtype=_DTYPES[dt])
    if dt == "<f8" and not np.all(np.isfinite(b)):
        raise ArtefactError(f"array {name!r}: non-finite value(s); a law must be finite numbers")
    return {"dtype": dt, "shape": list(b.shape), "data": base64.b64encode(b.tobytes()).decode("ascii")}


def _body(art: Artefact) -> dict[str, Any]:
    arrays = {k: _encode_array(k, v) for k, v in art.data.items() if isinstance(v, np.ndarray)}
    params = {k: v for k, v in art.data.items() if not isinstance(v, np.ndarray)}
    spec = asdict(art.spec)
    return {"format": FORMAT, "format_version": FORMAT_VERSION, "kind": art.kind, "spec": spec, "sensors": art.sensors,
            "limits": art.limits, "params": params, "arrays": arrays, "provenance": art.provenance}


def canonical(body: Mapping[str, Any]) -> bytes:
    """The bytes that the checksum and the signature cover."""
    try:
        return json.dumps(body, sort_keys=True, separators=(",", ":"), ensure_ascii=True, allow_nan=False).encode("ascii")
    except (TypeError, ValueError) as e:
        raise ArtefactError(f"not plain finite JSON data: {e}") from None


def save(art: Artefact, path: str | os.PathLike, key: bytes | str | None = None, overwrite: bool = True) -> str:
    """Write ``art`` to ``path`` (atomically: temporary file then rename); returns the SHA-256 hex digest.

    key: optional shared HMAC-SHA256 key (bytes, or a str encoded as UTF-8; at least 16 bytes); the file then
    carries a signature.  overwrite: False refuses an existing ``path`` (FileExistsError naming it), also one that
    appears while writing (the file is linked into place, never renamed over another).  The law is checked as
    :func:`load` checks it (its kind's ``from_data``, shapes against the spec) before anything is written, so a
    file this writes is one :func:`load` accepts; ArtefactError naming what is refused otherwise.
    """
    body = _body(art)
    _check_body(body, str(path))
    _check_law(art, str(path))  # a gain matrix of the wrong shape was written, and refused only when loaded
    raw = canonical(body)
    doc = dict(body, sha256=hashlib.sha256(raw).hexdigest())
    if key is not None:
        doc["signature"] = {"alg": "HMAC-SHA256", "value": hmac.new(_key(key), raw, hashlib.sha256).hexdigest()}
    p = Path(path)
    # named here: otherwise the error names the temporary file ("'/x/law.json.tmp' -> ...", "no such file ...tmp")
    if p.is_dir():
        raise IsADirectoryError(errno.EISDIR, "is a directory; an artefact is written to a file path", str(p))
    if not p.parent.is_dir():
        raise FileNotFoundError(errno.ENOENT, "no such directory to write the artefact into", str(p.parent))
    if not overwrite and os.path.lexists(p):
        raise FileExistsError(errno.EEXIST, "already exists; refusing to overwrite it", str(p))
    tmp = p.with_name(p.name + ".tmp")
    try:
        tmp.write_text(json.dumps(doc, indent=1, sort_keys=True, allow_nan=False) + "\n", encoding="ascii")
        if overwrite:
            os.replace(tmp, p)
        else:
            _link_new(tmp, p)
    finally:  # a failed write or rename leaves no temporary file behind
        tmp.unlink(missing_ok=True)
    return doc["sha256"]


def _link_new(tmp: Path, p: Path) -> None:
    """Move ``tmp`` to the new path ``p``: a hard link (FileExistsError if ``p`` exists by now), or, on a file
    system without hard links, a rename after checking that ``p`` still does not exist."""
    try:
        os.link(tmp, p)
    except FileExistsError:
        raise FileExistsError(errno.EEXIST, "already exists; refusing to overwrite it", str(p)) from None
    except OSError:  # no hard links here (EPERM, ENOTSUP, ...)
        if os.path.lexists(p):
            raise FileExistsError(errno.EEXIST, "already exists; refusing to overwrite it", str(p)) from None
        os.replace(tmp, p)


def _key(key: bytes | str) -> bytes:
    k = key.encode() if isinstance(key, str) else bytes(key)
    if len(k) < 16:
        raise ArtefactError(f"signing key: {len(k)} bytes; use at least 16 bytes")
    return k


# ---------------------------------------------------------------------- loading
def load(path: str | os.PathLike, key: bytes | str | None = None, require_signature: bool = False) -> Artefact:
    """Read and validate an artefact; any failure is an :class:`ArtefactError` naming what failed.

    Checks, in order: a regular file (a FIFO, device or directory is refused without blocking on it),
    size, JSON syntax (ASCII; no duplicate keys, no NaN / Infinity, integers of at most
    :data:`MAX_INT_DIGITS` digits, nesting at most :data:`MAX_DEPTH` deep), schema (keys and types),
    format and version (an int, not a bool), checksum (64 lowercase hex digits), signature (when ``key``
    is given, or required), array dtypes / shapes / finiteness, the spec's consistency (finite, ordered
    airspeed range, distinct names), and the kind's own ``from_data`` (shapes against the spec).  Any
    other failure inside the checks is still an ArtefactError naming the file, never a traceback.
    """
    where = str(Path(path))
    raw_bytes = _read_regular(where)
    try:
        return _load(where, raw_bytes, key, require_signature)
    except ArtefactError:
        raise
    except (TypeError, KeyError, IndexError, ValueError, OverflowError, RecursionError, AttributeError) as e:  # a check that did not foresee a type
        raise ArtefactError(f"{where}: malformed artefact ({type(e).__name__}: {e})") from None


def _read_regular(where: str) -> bytes:
    """The bytes of ``where`` if it is a regular file of at most MAX_BYTES (opened non-blocking: a FIFO never hangs)."""
    try:
        fd = os.open(where, os.O_RDONLY | getattr(os, "O_NONBLOCK", 0))
    except OSError as e:
        raise ArtefactError(f"{where}: cannot read ({e.strerror})") from None
    try:
        st = os.fstat(fd)
        if not stat.S_ISREG(st.st_mode):
            raise ArtefactError(f"{where}: not a regular file (a directory, FIFO, socket or device); an artefact is a file")
        if st.st_size > MAX_BYTES:
            raise ArtefactError(f"{where}: {st.st_size} bytes; larger than the {MAX_BYTES}-byte limit")
        chunks, n = [], 0
        while n <= MAX_BYTES and (chunk := os.read(fd, 1 << 20)):
            chunks.append(chunk)
            n += len(chunk)
    except OSError as e:
        raise ArtefactError(f"{where}: cannot read ({e.strerror})") from None
    finally:
        os.close(fd)
    if n > MAX_BYTES:
        raise ArtefactError(f"{where}: larger than the {MAX_BYTES}-byte limit")
    return b"".join(chunks)


def _depth(raw: bytes) -> int:
    """Deepest nesting of ``[`` / ``{`` in JSON text ``raw``, outside strings (numpy: no recursion)."""
    text = re.sub(rb'"(?:[^"\\]|\\.)*"', b'""', raw)
    c = np.frombuffer(text, dtype=np.uint8)
    step = np.isin(c, (ord("["), ord("{"))).astype(np.int64) - np.isin(c, (ord("]"), ord("}")))
    return int(np.cumsum(step).max()) if step.size else 0


def _no_duplicates(pairs: list[tuple[str, Any]]) -> dict[str, Any]:
    out: dict[str, Any] = {}
    for k, v in pairs:
        if k in out:
            raise ArtefactError(f"duplicate key {k!r} in a JSON object (which value counts would be ambiguous)")
        out[k] = v
    return out


def _parse_int(s: str) -> int:
    if len(s.lstrip("-")) > MAX_INT_DIGITS:
        raise ArtefactError(f"integer of {len(s.lstrip('-'))} digits (at most {MAX_INT_DIGITS})")
    return int(s)


def _parse_float(s: str) -> float:
    v = float(s)
    if not math.isfinite(v):
        raise ArtefactError(f"number {s[:40]} overflows a float64")
    return v


def _load(where: str, raw_bytes: bytes, key: bytes | str | None, require_signature: bool) -> Artefact:
    if _depth(raw_bytes) > MAX_DEPTH:
        raise ArtefactError(f"{where}: JSON nested deeper than {MAX_DEPTH} levels")
    try:
        doc = json.loads(raw_bytes.decode("ascii"), parse_constant=_no_constant, object_pairs_hook=_no_duplicates,
                         parse_int=_parse_int, parse_float=_parse_float)
    except (UnicodeDecodeError, json.JSONDecodeError, ArtefactError, RecursionError) as e:
        raise ArtefactError(f"{where}: not a valid JSON artefact (truncated or corrupted?): {e}") from None
    if not isinstance(doc, dict):
        raise ArtefactError(f"{where}: top level must be a JSON object")
    if doc.get("format") == OLD_POLICY_FORMAT:
        raise ArtefactError(f"{where}: an old-format policy file (format {OLD_POLICY_FORMAT!r}, the separate policy format that "
                            f"rig-law artefacts replaced); convert it once with: rig-deploy convert-policy {where} NEW.json")
    missing = [k for k in _BODY_KEYS + ("sha256",) if k not in doc]
    if missing:
        raise ArtefactError(f"{where}: missing key(s) {missing}")
    extra = sorted(set(doc) - set(_BODY_KEYS) - {"sha256", "signature"})
    if extra:
        raise ArtefactError(f"{where}: unknown key(s) {extra}")
    if doc["format"] != FORMAT:
        raise ArtefactError(f"{where}: format {doc['format']!r}, expected {FORMAT!r}")
    if type(doc["format_version"]) is not int or doc["format_version"] != FORMAT_VERSION:
        raise ArtefactError(f"{where}: format_version {doc['format_version']!r}; this runtime reads version {FORMAT_VERSION} only")
    body = {k: doc[k] for k in _BODY_KEYS}
    raw = canonical(body)
    digest = hashlib.sha256(raw).hexdigest()
    if not isinstance(doc["sha256"], str) or not _HEX64.fullmatch(doc["sha256"]):
        raise ArtefactError(f"{where}: sha256 must be 64 lowercase hex digits, got {str(doc['sha256'])[:70]!r}")
    if not hmac.compare_digest(digest, doc["sha256"]):
        raise ArtefactError(f"{where}: checksum mismatch (sha256 of the content is {digest[:16]}..., file says {str(doc['sha256'])[:16]}...): the file was modified or damaged")
    sig = doc.get("signature")
    if key is not None or require_signature:
        if key is None:
            raise ArtefactError(f"{where}: a signature is required but no key was given")
        if not isinstance(sig, dict) or sig.get("alg") != "HMAC-SHA256" or not isinstance(sig.get("value"), str) or not _HEX64.fullmatch(sig["value"]):
            raise ArtefactError(f"{where}: signature missing or malformed (expected HMAC-SHA256)")
        want = hmac.new(_key(key), raw, hashlib.sha256).hexdigest()
        if not hmac.compare_digest(want, sig["value"]):
            raise ArtefactError(f"{where}: signature does not match (wrong key, or the file was re-checksummed after editing)")
    spec, data = _check_body(body, where)
    art = Artefact(body["kind"], spec, dict(body["sensors"]), dict(body["limits"]), data, dict(body["provenance"]), digest)
    _check_law(art, where)
    return art


def _check_law(art: Artefact, where: str) -> None:
    """The kind's own ``from_data`` validates the law's data (shapes against the spec): ArtefactError naming ``where``."""
    try:
        art.controller()
    except ArtefactError:
        raise
    except (ValueError, KeyError, TypeError) as e:
        raise ArtefactError(f"{where}: kind {art.kind!r} refused its data: {e}") from None


def _no_constant(name: str) -> None:
    raise ArtefactError(f"non-finite constant {name} in the file")


def _check_body(body: Mapping[str, Any], where: str) -> tuple[LoopSpec, dict[str, Any]]:
    def need(cond: bool, what: str) -> None:
        if not cond:
            raise ArtefactError(f"{where}: {what}")

    need(isinstance(body["kind"], str), "kind must be a string")
    s = body["spec"]
    need(isinstance(s, dict), "spec must be an object")
    fields = {"task": str, "free_dofs": list, "obs_labels": list, "action_names": list, "dt": float, "airspeed_range": list, "action_scale_deg": float}
    for k, t in fields.items():
        v = s.get(k) if isinstance(s, dict) else None
        ok = isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) if t is float else isinstance(v, (list, tuple) if t is list else t)
        need(ok, f"spec.{k} missing or not a {t.__name__}")
    optional = {"task_options", "aero_model"}  # absent in older artefacts: {} and "linear"
    need(set(s) <= set(fields) | optional, f"spec: unexpected key(s) {sorted(set(s) - set(fields) - optional)}")
    need(s.get("aero_model", "linear") in AERO_MODELS, f"spec.aero_model = {s.get('aero_model')!r}: one of {list(AERO_MODELS)}")
    opts = s.get("task_options", {})
    need(isinstance(opts, dict) and all(isinstance(k, str) and isinstance(v, (str, int, float, bool)) for k, v in opts.items()),
         "spec.task_options must be an object of scalar values")
    for k in ("free_dofs", "obs_labels", "action_names"):
        need(len(s[k]) > 0 and all(isinstance(x, str) for x in s[k]), f"spec.{k} must be a non-empty list of strings")
        need(len(set(s[k])) == len(s[k]), f"spec.{k} = {s[k]}: names repeat")
    ar = s["airspeed_range"]
    need(len(ar) == 2 and all(isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) for v in ar) and 0.0 <= ar[0] <= ar[1],
         f"spec.airspeed_range = {ar!r}: two finite speeds lo <= hi, m/s, lo >= 0")
    need(0.0 < s["dt"] <= 1.0, f"spec.dt = {s['dt']} s: allowed range (0, 1]")
    need(0.0 < s["action_scale_deg"] <= 90.0, f"spec.action_scale_deg = {s['action_scale_deg']}: allowed range (0, 90]")
    spec = LoopSpec(s["task"], tuple(s["free_dofs"]), tuple(s["obs_labels"]), tuple(s["action_names"]), float(s["dt"]),
                    tuple(float(v) for v in s["airspeed_range"]), float(s["action_scale_deg"]), dict(opts), str(s.get("aero_model", "linear")))
    sen = body["sensors"]
    need(isinstance(sen, dict) and set(sen) == set(_SENSOR_KEYS), f"sensors: keys must be {sorted(_SENSOR_KEYS)}")
    for k, t in _SENSOR_KEYS.items():
        v = sen[k]
        ok = isinstance(v, bool) if t is bool else (isinstance(v, (int, float)) and not isinstance(v, bool) and math.isfinite(v) and (t is float or float(v).is_integer()))
        need(ok, f"sensors.{k} = {v!r}: must be a {t.__name__}")
    need(0.0 < sen["rate_filter_hz"] <= 0.5 / spec.dt, f"sensors.rate_filter_hz = {sen['rate_filter_hz']}: allowed range (0, {0.5 / spec.dt}] Hz")
    lim = body["limits"]
    need(isinstance(lim, dict) and set(lim) == {"position_deg", "rate_deg_s"}, "limits: keys must be ['position_deg', 'rate_deg_s']")
    for k, hi in (("position_deg", 90.0), ("rate_deg_s", 5000.0)):
        v = lim[k]
        need(isinstance(v, list) and len(v) == spec.n_actions, f"limits.{k}: need {spec.n_actions} values (one per action)")
        need(all(isinstance(x, (int, float)) and not isinstance(x, bool) and 0.0 < x <= hi for x in v), f"limits.{k} = {v}: each in (0, {hi}]")
    need(isinstance(body["params"], dict), "params must be an object")
    need(isinstance(body["provenance"], dict), "provenance must be an object")
    arrs = body["arrays"]
    need(isinstance(arrs, dict), "arrays must be an object")
    data: dict[str, Any] = dict(body["params"])
    for name, a in arrs.items():
        need(isinstance(a, dict) and set(a) == {"dtype", "shape", "data"}, f"arrays.{name}: needs exactly dtype, shape, data")
        need(isinstance(a["dtype"], str) and a["dtype"] in _DTYPES, f"arrays.{name}.dtype = {a['dtype']!r}: allowed {sorted(_DTYPES)}")
        shp = a["shape"]
        need(isinstance(shp, list) and len(shp) <= 4 and all(isinstance(d, int) and not isinstance(d, bool) and 0 <= d <= 2**24 for d in shp), f"arrays.{name}.shape = {shp!r}: up to 4 non-negative integers")
        try:
            buf = base64.b64decode(a["data"], validate=True) if isinstance(a["data"], str) else None
        except ValueError:
            buf = None
        need(buf is not None, f"arrays.{name}.data: not valid base64")
        dt = _DTYPES[a["dtype"]]
        need(len(buf) == math.prod(shp) * dt.itemsize, f"arrays.{name}: {len(buf)} bytes of data for shape {shp} ({math.prod(shp) * dt.itemsize} expected; truncated?)")
        arr = np.frombuffer(buf, dtype=dt).reshape(shp).astype(dt.newbyteorder("="))
        need(bool(np.all(np.isfinite(arr))), f"arrays.{name}: non-finite value(s)")
        data[name] = arr
    return spec, data
