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
