"""Schemathesis hooks for Preston's contract checks (see contract/schemathesis.toml)."""

import json

import schemathesis
from schemathesis.generation.modes import GenerationMode

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
