"""Drive the client openapi-python-client generates from openapi/openapi.json.

Every POST fixture goes through the generated client to the running service and must come back
200 and parse into the generated response model; every stored response in fixtures/expected/
must parse into that model too. Run by .ci/run:

    python contract/python_client_check.py <generated client dir> <base url>
"""

import json
import pathlib
import sys

client_dir, base_url = sys.argv[1], sys.argv[2]
sys.path.insert(0, client_dir)

from preston_client import Client  # noqa: E402
from preston_client.api.calibration import calibrate  # noqa: E402
from preston_client.api.machine import generate_program  # noqa: E402
from preston_client.api.maps import (  # noqa: E402
    analyse_map,
    compute_map_removal_function,
    difference_maps,
    generate_map_program,
    optimize_map,
    predict_removal_map,
)
from preston_client.api.metrology import fit_measurement  # noqa: E402
from preston_client.api.optimize import optimize_dwell  # noqa: E402
from preston_client.api.recommend import recommend_speeds, sweep_eta  # noqa: E402
from preston_client.api.removal import compute_removal_function, predict_removal  # noqa: E402
from preston_client import models  # noqa: E402

# fixture name prefix -> (operation module, request model, response model)
OPERATIONS = {
    "removal_function_": (
        compute_removal_function,
        models.RemovalFunctionRequest,
        models.RemovalFunctionResponse,
    ),
    "predict_": (predict_removal, models.PredictRequest, models.PredictResponse),
    "optimize_": (optimize_dwell, models.OptimizeRequest, models.OptimizeResponse),
    "recommend_": (recommend_speeds, models.RecommendRequest, models.RecommendResponse),
    "eta_sweep_": (sweep_eta, models.EtaSweepRequest, models.EtaSweepResponse),
    "measurement_fit_": (
        fit_measurement,
        models.MeasurementFitRequest,
        models.MeasurementFitResponse,
    ),
    "program_": (generate_program, models.ProgramRequest, models.ProgramResponse),
    "calibration_": (calibrate, models.CalibrationRequest, models.CalibrationResponse),
    "maps_analysis": (analyse_map, models.MapAnalysisRequest, models.MapAnalysisResponse),
    "maps_difference": (
        difference_maps,
        models.MapDifferenceRequest,
        models.MapDifferenceResponse,
    ),
    "maps_removal_function": (
        compute_map_removal_function,
        models.MapRemovalFunctionRequest,
        models.MapRemovalFunctionResponse,
    ),
    "maps_predict": (predict_removal_map, models.MapPredictRequest, models.MapPredictResponse),
    "maps_optimize": (optimize_map, models.MapOptimizeRequest, models.MapOptimizeResponse),
    "maps_program": (
        generate_map_program,
        models.MapProgramRequest,
        models.MapProgramResponse,
    ),
}

root = pathlib.Path(__file__).resolve().parent.parent
client = Client(base_url=base_url, timeout=60.0, raise_on_unexpected_status=True)
calls = parsed = 0
seen = set()
for fixture in sorted((root / "fixtures").glob("*.json")):
    prefix = next(p for p in OPERATIONS if fixture.name.startswith(p))
    operation, request_model, response_model = OPERATIONS[prefix]
    seen.add(prefix)
    body = request_model.from_dict(json.loads(fixture.read_text()))
    reply = operation.sync_detailed(client=client, body=body)
    if reply.status_code != 200 or not isinstance(reply.parsed, response_model):
        sys.exit(f"{fixture.name}: {reply.status_code} {reply.content[:300]!r}")
    # The typed response round-trips to the JSON the service sent.
    sent = json.loads(reply.content)
    if reply.parsed.to_dict() != sent:
        sys.exit(f"{fixture.name}: the parsed response does not round-trip")
    calls += 1
    stored = json.loads((root / "fixtures" / "expected" / fixture.name).read_text())
    if response_model.from_dict(stored).to_dict() != stored:
        sys.exit(f"expected/{fixture.name}: the stored response does not round-trip")
    parsed += 1
missing = set(OPERATIONS) - seen
if missing:
    sys.exit(f"no fixture exercises {sorted(missing)}")
print(f"python client: {calls} fixtures called through the generated client, {parsed} stored responses parsed")
