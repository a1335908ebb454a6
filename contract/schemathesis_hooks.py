"""Schemathesis hooks for Preston's contract checks (see contract/schemathesis.toml)."""

import json

import hypothesis.internal.lambda_sources as lambda_sources
import schemathesis
from schemathesis.generation.modes import GenerationMode

# CPython 3.11's `ast` can raise SystemError "AST constructor recursion depth mismatch" when Hypothesis
# parses a lambda's source to describe it, deep inside schemathesis's recursive schema walk
# (the stack depth changes between the parse and its check). The description only names a
# filter in reprs; without this, the run stops on that error (a tool failure, not a finding).
_describe = lambda_sources._lambda_description


def _described_or_unknown(f, *args, **kwargs):
    try:
        return _describe(f, *args, **kwargs)
    except (SystemError, RuntimeError, RecursionError):
        return "lambda: <unknown>"


lambda_sources._lambda_description = _described_or_unknown

# Problem types that say the request does not fit the schema (or is not JSON at all).
SCHEMA_PROBLEMS = {
    "urn:preston:problem:schema-mismatch",
    "urn:preston:problem:malformed-json",
}


@schemathesis.check
def schema_valid_data_never_mismatches_the_schema(ctx, response, case):
    """Schema-valid data may be refused only for a rule the schema cannot state."""
    meta = case.meta
    if meta is None or meta.generation.mode != GenerationMode.POSITIVE:
        return None
    if response.status_code not in (400, 422):
        return None
    try:
        problem = json.loads(response.content)
    except ValueError:
        raise AssertionError(f"{response.status_code} without a problem body")
    if problem.get("type") in SCHEMA_PROBLEMS:
        raise AssertionError(
            f"schema-valid data refused as {problem.get('type')} at "
            f"{problem.get('field')}: {problem.get('detail')}"
        )
    return None


# --- Stateful phase: record bodies the service can use -------------------------------------
#
# The record operations chain (profile -> part -> measurement -> plan -> run) and their OpenAPI
# links follow only a 201. A generated body almost never makes one: a part must name a profile
# that exists, a measurement must fit the part's surface, a run must name a plan of its part, and
# JSON Schema cannot say any of that, so the stateful phase covered 6 of 70 links. In the stateful
# phase only, for schema-valid (positive) cases only, and for about 7 cases in 10 (the rest keep
# the generated body, so generated data still reaches these operations), the body is replaced by
# one built from the README's worked cycle (fixtures/), with a fresh unique name, naming records
# this run created (seen in `after_call`). The path parameters (what the link supplies) are never
# touched. No check is weakened: a substituted body is kept only if schemathesis itself still
# judges it schema-valid (else the generated body is put back), so every check still applies to
# it, `schema_valid_data_never_mismatches_the_schema` included, as it would to generated data.

import copy
import itertools
import threading
import time
from pathlib import Path

from hypothesis import strategies as st
from schemathesis.core.parameters import ParameterLocation
from schemathesis.generation.meta import TestPhase

_FIXTURES = Path(__file__).resolve().parent.parent / "fixtures"


def _fixture(name):
    with open(_FIXTURES / name, encoding="utf-8") as f:
        return json.load(f)


# The README's "Parts and cycles" example: process, asphere, the two measurements, the rings.
_FIT = _fixture("measurement_fit_asphere.json")
_FIT_AFTER = _fixture("parts/measurement_after_asphere.json")
_RINGS = _fixture("calibration_rings.json")
_PROCESS = _RINGS["process"]
_SURFACE = _FIT["surface"]
_APERTURE = _FIT["clear_aperture"]
_RADIUS_MM = _PROCESS["workpiece_radius_mm"]
_POSITIONS_MM = [i / 2 for i in range(91)]  # 0 to 45 mm, inside the 40 mm aperture's reach


def _measurement(fit):
    # A part measurement is a /v1/measurement/fit request without surface; the aperture is the part's.
    return {k: v for k, v in fit.items() if k not in ("surface", "clear_aperture")}


_MEASUREMENT_BEFORE = _measurement(_FIT)
_MEASUREMENT_AFTER = _measurement(_FIT_AFTER)
_PROFILE_CALIBRATION = {k: v for k, v in _RINGS.items() if k != "process"}

# What this run created with usable data, learned from the 201s (any phase). A list, not a set,
# so the choice below is reproducible for a seed.
_lock = threading.Lock()
_profiles = []  # profile names whose process is _PROCESS
_parts = []  # ids of parts on such a profile with the asphere, radius and aperture above
_measured = set()  # parts with a measurement
_ran = set()  # parts with a run
_plans = {}  # part id -> its plan ids
_serial = itertools.count(1)
_run_tag = f"{int(time.time()):x}"  # names stay unique if the database is reused


def _unique(prefix):
    return f"{prefix}-{_run_tag}-{next(_serial)}"


def _profile_body(case):
    return {"name": _unique("st-profile"), "process": copy.deepcopy(_PROCESS)}


def _part_body(case):
    with _lock:
        if not _profiles:
            return None
        profile = _profiles[next(_serial) % len(_profiles)]
    return {
        "name": _unique("st-part"),
        "process_profile": profile,
        "surface": copy.deepcopy(_SURFACE),
        "workpiece_radius_mm": _RADIUS_MM,
        "clear_aperture": copy.deepcopy(_APERTURE),
    }


def _measurement_body(case):
    part = case.path_parameters.get("id")
    if case.media_type != "application/json":
        return None  # the text/csv form keeps its generated body
    with _lock:
        if part not in _parts:
            return None
        ran = part in _ran
    # After a run the part is measured again: that completes the cycle (history, learned K).
    return copy.deepcopy(_MEASUREMENT_AFTER if ran else _MEASUREMENT_BEFORE)


def _plan_body(case):
    part = case.path_parameters.get("id")
    with _lock:
        if part not in _parts:
            return None
        measured = part in _measured
    body = {"positions_mm": list(_POSITIONS_MM)}
    if not measured:
        # Nothing measured yet: the plan needs a target of its own.
        body["target"] = {"uniform_depth_nm": 100.0}
    return body


def _run_body(case):
    part = case.path_parameters.get("id")
    with _lock:
        plans = _plans.get(part)
        if not plans:
            return None
        plan = plans[-1]
    # RFC 3339 UTC; a run may not start before its plan was made (5 minutes' slack), and it
    # takes the README's 4 h 18 min.
    start = int(time.time())
    stamp = lambda t: time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(t))  # noqa: E731
    return {"plan_id": plan, "started_at": stamp(start), "finished_at": stamp(start + 15480), "machine": "cell 3"}


def _profile_calibration_body(case):
    with _lock:
        if case.path_parameters.get("name") not in _profiles:
            return None
    return copy.deepcopy(_PROFILE_CALIBRATION)


def _program_body(case):
    # Every option defaulted: the plan's process, surface and dwell on the default machine.
    return {}


_BODIES = {
    ("POST", "/v1/process-profiles"): _profile_body,
    ("POST", "/v1/parts"): _part_body,
    ("POST", "/v1/parts/{id}/measurements"): _measurement_body,
    ("POST", "/v1/parts/{id}/plans"): _plan_body,
    ("POST", "/v1/parts/{id}/runs"): _run_body,
    ("POST", "/v1/process-profiles/{name}/calibrations"): _profile_calibration_body,
    ("POST", "/v1/plans/{id}/program"): _program_body,
}
# Out of 10 draws, how many substitute (the rest keep the generated body).
_SUBSTITUTE_OUT_OF_10 = 7


def _operation_key(operation):
    return operation.method.upper(), operation.path


def _substituted(case, build):
    body = build(case)
    if body is None:
        return case
    original, original_query = case.body, case.query
    case.body = body
    if case.operation.path == "/v1/parts/{id}/measurements" and case.query:
        # Its query parameters configure a text/csv body; with a JSON body they are a 422.
        case.query = {}
    meta = case.meta  # revalidates the replaced body against the schema
    body_info = meta.components.get(ParameterLocation.BODY) if meta is not None else None
    if body_info is None or not body_info.mode.is_positive or meta.generation.mode != GenerationMode.POSITIVE:
        case.body, case.query = original, original_query  # not schema-valid after all: keep the generated data
        case.meta  # noqa: B018 (revalidate back)
        return case
    # A repeated generated Idempotency-Key with this new body would be a 422 (same key, another
    # request); keep the header, made unique (still 1-255 visible ASCII).
    for name in list(case.headers or {}):
        if name.lower() == "idempotency-key":
            case.headers[name] = f"{str(case.headers[name])[:200]}.{_unique('st')}"
    return case


@schemathesis.hook
def flatmap_case(context, case):
    build = _BODIES.get(_operation_key(context.operation)) if context.operation is not None else None
    meta = case.meta
    if (
        build is None
        or meta is None
        or meta.phase.name != TestPhase.STATEFUL
        or meta.generation.mode != GenerationMode.POSITIVE
    ):
        return st.just(case)
    # A Hypothesis draw (not `random`), so the mix is reproducible for a seed.
    return st.integers(min_value=0, max_value=9).map(
        lambda n: _substituted(case, build) if n < _SUBSTITUTE_OUT_OF_10 else case
    )


@schemathesis.hook
def after_call(context, case, response):
    """Remember records created with usable data, for the bodies above."""
    if response.status_code != 201 or context.operation is None:
        return
    key = _operation_key(context.operation)
    if key not in _BODIES:
        return
    try:
        record = json.loads(response.content)
    except ValueError:
        return
    if not isinstance(record, dict):
        return
    with _lock:
        if key == ("POST", "/v1/process-profiles"):
            if _same_process(record.get("process")):
                _profiles.append(record.get("name"))
        elif key == ("POST", "/v1/parts"):
            if (
                record.get("process_profile") in _profiles
                and record.get("surface") == _SURFACE
                and record.get("workpiece_radius_mm") == _RADIUS_MM
                and record.get("clear_aperture") == _APERTURE
            ):
                _parts.append(record.get("id"))
        elif key == ("POST", "/v1/parts/{id}/measurements"):
            _measured.add(record.get("part_id"))
        elif key == ("POST", "/v1/parts/{id}/plans"):
            _plans.setdefault(record.get("part_id"), []).append(record.get("id"))
        elif key == ("POST", "/v1/parts/{id}/runs"):
            _ran.add(record.get("part_id"))


def _same_process(process):
    return isinstance(process, dict) and all(process.get(k) == v for k, v in _PROCESS.items())
