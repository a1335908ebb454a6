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
# links follow only a 201. A generated body almost never gets one: a part must name a profile
# that exists, a measurement must fit the part's surface, a run must name a plan of its part (JSON
# Schema cannot say any of that), so the stateful phase covered 6 of 70 links. In the stateful
# phase only, and only for schema-valid (positive) cases, about 7 bodies in 10 of these
# operations are replaced by one built from the README's worked cycle (fixtures/), naming records
# this run created (seen in `after_call`) and a fresh unique name; the rest keep the generated
# body, so generated data still reaches them (its unique `name` made unique, see _renamed_body).
# The path parameters (what a link supplies) are never touched. No check is weakened: a body is
# replaced only if schemathesis itself still judges the case schema-valid afterwards (else the
# generated one is put back), so every check applies to it as to generated positive data,
# `schema_valid_data_never_mismatches_the_schema` included.

import copy
import itertools
import threading
import time
from pathlib import Path

import requests
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
_POSITIONS_MM = [i / 2 for i in range(91)]  # 0 to 45 mm, as in the README


def _measurement(fit):
    # A part's measurement is a /v1/measurement/fit request without surface; the aperture is the part's.
    return {k: v for k, v in fit.items() if k not in ("surface", "clear_aperture")}


_MEASUREMENT_BEFORE = _measurement(_FIT)
_MEASUREMENT_AFTER = _measurement(_FIT_AFTER)
_PROFILE_CALIBRATION = {k: v for k, v in _RINGS.items() if k != "process"}

# What this run created with usable data, learned from the 201s. Lists, so choices are ordered.
_lock = threading.Lock()
_profiles = []  # names of profiles whose process is _PROCESS
_parts = []  # ids of parts on such a profile with _SURFACE, _RADIUS_MM and _APERTURE
_measured = set()  # parts with a measurement
_ran = set()  # parts with a run
_plans = {}  # part id -> its plan ids
_serial = itertools.count(1)
_run_tag = f"{int(time.time()):x}"  # names stay unique if the records store is reused
_seeded = False


def _unique(prefix):
    return f"{prefix}-{_run_tag}-{next(_serial)}"


def _profile_body(case):
    return {"name": _unique("st-profile"), "process": copy.deepcopy(_PROCESS)}


def _seed_profile(case):
    """The first part needs a profile: create one (as the README does) if none was seen yet.

    Otherwise the first scenarios' parts are a 422 and later ones with the same steps a 201, and
    Hypothesis, replaying such a prefix, ends the phase early ("inconsistent data generation").
    """
    global _seeded
    with _lock:
        if _profiles or _seeded:
            return
        _seeded = True
    body = _profile_body(case)
    try:
        response = requests.post(
            case.operation.schema.get_base_url() + "/v1/process-profiles", json=body, timeout=30
        )
    except requests.RequestException:
        return
    if response.status_code == 201:
        with _lock:
            _profiles.append(body["name"])


def _part_body(case):
    _seed_profile(case)
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
    if case.media_type != "application/json":
        return None  # the text/csv form keeps its generated body
    part = case.path_parameters.get("id")
    with _lock:
        if part not in _parts:
            return None
        ran = part in _ran
    # Measured again after a run, the part completes a cycle (history, a learned K).
    return copy.deepcopy(_MEASUREMENT_AFTER if ran else _MEASUREMENT_BEFORE)


def _plan_body(case):
    part = case.path_parameters.get("id")
    with _lock:
        if part not in _parts:
            return None
        measured = part in _measured
    body = {"positions_mm": list(_POSITIONS_MM)}
    if not measured:
        # With nothing measured the plan needs a target of its own.
        body["target"] = {"uniform_depth_nm": 100.0}
    return body


def _run_body(case):
    part = case.path_parameters.get("id")
    with _lock:
        plans = _plans.get(part)
        if not plans:
            return None
        plan = plans[-1]
    # RFC 3339 UTC, starting now (after its plan was made), taking the README's 4 h 18 min.
    start = int(time.time())
    stamp = lambda t: time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(t))  # noqa: E731
    return {"plan_id": plan, "started_at": stamp(start), "finished_at": stamp(start + 15480), "machine": "cell 3"}


def _profile_calibration_body(case):
    with _lock:
        if case.path_parameters.get("name") not in _profiles:
            return None
    return copy.deepcopy(_PROFILE_CALIBRATION)


def _program_body(case):
    return {}  # every option defaulted: the plan's process, surface and dwell, the default machine


_BODIES = {
    ("POST", "/v1/process-profiles"): _profile_body,
    ("POST", "/v1/parts"): _part_body,
    ("POST", "/v1/parts/{id}/measurements"): _measurement_body,
    ("POST", "/v1/parts/{id}/plans"): _plan_body,
    ("POST", "/v1/parts/{id}/runs"): _run_body,
    ("POST", "/v1/process-profiles/{name}/calibrations"): _profile_calibration_body,
    ("POST", "/v1/plans/{id}/program"): _program_body,
}
# Out of 10 cases, how many get a body above (the rest keep the generated one).
_SUBSTITUTE_OUT_OF_10 = 7
# Operations whose `name` is unique, with its longest length.
_NAME_MAX_LENGTH = {("POST", "/v1/process-profiles"): 64, ("POST", "/v1/parts"): 200}


def _renamed_body(case):
    """The generated body with its name made unique (a suffix of [A-Za-z0-9.-], within the length).

    A Hypothesis scenario that reuses an earlier one's steps sends the same generated name again:
    a 201 the first time, a 409 the second, so the scenario takes another course and Hypothesis
    ends the phase ("inconsistent data generation"). The 409 itself is tested in the other phases.
    """
    body = case.body
    if not isinstance(body, dict) or not isinstance(body.get("name"), str):
        return None
    suffix = "." + _unique("g")
    limit = _NAME_MAX_LENGTH[_operation_key(case.operation)]
    return {**body, "name": body["name"][: limit - len(suffix)] + suffix}


def _operation_key(operation):
    return operation.method.upper(), operation.path


def _with_body(case, build):
    """`case` with the body `build` gives, if there is one and the case stays schema-valid."""
    body = build(case)
    if body is None:
        return case
    original = case.body, case.query, case.headers
    case.body = body
    if case.operation.path == "/v1/parts/{id}/measurements" and case.query:
        # Its query parameters configure a text/csv body; with a JSON body they are a 422.
        case.query = {}
    if case.headers:
        # The same Idempotency-Key with another request is a 422, and a scenario replayed by
        # Hypothesis sends the same generated key again: keep the header, made unique.
        headers = case.headers.copy()
        for name in list(headers):
            if name.lower() == "idempotency-key":
                headers[name] = f"{str(headers[name])[:200]}.{_unique('st')}"
        case.headers = headers
    meta = case.meta  # revalidates the changed parts against the schema
    body_info = meta.components.get(ParameterLocation.BODY) if meta is not None else None
    if body_info is None or not body_info.mode.is_positive or meta.generation.mode != GenerationMode.POSITIVE:
        case.body, case.query, case.headers = original  # keep the generated data
        case.meta  # noqa: B018 (revalidated back)
    return case


# Registered for these operations only: every other operation's strategy stays as it was.
_RECORD_POSTS = sorted(path for _, path in _BODIES)


@schemathesis.hook.apply_to(method="POST", path=_RECORD_POSTS)
def flatmap_case(context, case):
    key = _operation_key(context.operation) if context.operation is not None else None
    build = _BODIES.get(key)
    meta = case.meta
    if (
        build is None
        or meta is None
        or meta.phase.name != TestPhase.STATEFUL
        or meta.generation.mode != GenerationMode.POSITIVE
    ):
        return st.just(case)
    rename = _renamed_body if key in _NAME_MAX_LENGTH else None

    def choose(n):
        if n < _SUBSTITUTE_OUT_OF_10:
            return _with_body(case, build)
        return _with_body(case, rename) if rename is not None else case

    # A Hypothesis draw (not `random`), so the mix is reproducible for a seed.
    return st.integers(min_value=0, max_value=9).map(choose)


@schemathesis.hook.apply_to(method="POST", path=_RECORD_POSTS)
def after_call(context, case, response):
    """Remember the records created with usable data, for the bodies above."""
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
