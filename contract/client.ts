// A small front-end-style client of Preston, typed entirely by the types openapi-typescript
// generates from the committed openapi/openapi.json (schema.d.ts, not committed), with
// openapi-fetch. `tsc --strict` must accept it with no hand-edits to the generated types and no
// type assertions on response bodies; run with node, it posts every POST fixture to the
// service and checks the typed answers.
//
//     node dist/client.js <base url> <fixtures dir>

import { readFileSync, readdirSync } from "node:fs";
import { join } from "node:path";
import createClient from "openapi-fetch";
import type { components, paths } from "./schema.js";

type Schemas = components["schemas"];

const [baseUrl, fixtures] = process.argv.slice(2);
if (!baseUrl || !fixtures) {
  throw new Error("usage: client.js <base url> <fixtures dir>");
}
// JSON media types (answers are application/json, problems application/problem+json); the
// endpoints also offer text/csv and image/svg+xml.
const client = createClient<paths, `${string}/${string}json`>({ baseUrl });

function read<T>(name: string): T {
  // The request side: a fixture file is the caller's own input.
  return JSON.parse(readFileSync(join(fixtures, name), "utf8")) as T;
}

function check(name: string, ok: boolean, what: string): void {
  if (!ok) {
    throw new Error(`${name}: ${what}`);
  }
}

async function removalFunction(name: string): Promise<void> {
  const { data, error } = await client.POST("/v1/removal-function", {
    body: read<Schemas["RemovalFunctionRequest"]>(name),
  });
  check(name, error === undefined && data !== undefined, JSON.stringify(error));
  if (!data) return;
  const rows = data.radius_mm.length;
  check(name, data.profiles.every((p) => p.removal_rate_nm_per_min.length === rows), "profile lengths");
}

async function predict(name: string): Promise<void> {
  const { data, error } = await client.POST("/v1/predict", {
    body: read<Schemas["PredictRequest"]>(name),
  });
  check(name, error === undefined && data !== undefined, JSON.stringify(error));
  if (!data) return;
  const nonuniformity: number | null = data.metrics.nonuniformity;
  check(name, data.removal_nm.length === data.radius_mm.length, "removal length");
  check(name, nonuniformity === null || nonuniformity >= 0, "nonuniformity");
  const rule = data.recommendation?.rule;
  check(name, rule === undefined || rule === "match_removal_rate" || rule === "fastest_allowed", "rule");
  check(name, Array.isArray(data.warnings), "warnings");
}

async function optimize(name: string): Promise<void> {
  const { data, error } = await client.POST("/v1/optimize", {
    body: read<Schemas["OptimizeRequest"]>(name),
  });
  check(name, error === undefined && data !== undefined, JSON.stringify(error));
  if (!data) return;
  const status: Schemas["SolverStatusDto"] = data.solver.status;
  check(name, status === "solved" || status === "almost_solved", `status ${status}`);
  check(name, data.dwell.dwell_s.length === data.dwell.positions_mm.length, "plan lengths");
  check(name, data.warnings.every((w) => typeof w.message === "string"), "warnings");
}

async function recommend(name: string): Promise<void> {
  const { data, error } = await client.POST("/v1/recommend", {
    body: read<Schemas["RecommendRequest"]>(name),
  });
  check(name, error === undefined && data !== undefined, JSON.stringify(error));
  if (!data) return;
  check(name, data.recommendation.eta === -1, "eta");
  const low: number | null | undefined = data.recommendation.eta_window?.low;
  check(name, low === undefined || low === null || low < -1, "window");
}

async function etaSweep(name: string): Promise<void> {
  const body = read<Schemas["EtaSweepRequest"]>(name);
  const { data, error } = await client.POST("/v1/studies/eta-sweep", { body });
  check(name, error === undefined && data !== undefined, JSON.stringify(error));
  if (!data) return;
  check(name, data.points.length === body.etas.length, "one point per η");
}

async function measurementFit(name: string): Promise<void> {
  const body = read<Schemas["MeasurementFitRequest"]>(name);
  const { data, error } = await client.POST("/v1/measurement/fit", { body });
  check(name, error === undefined && data !== undefined, JSON.stringify(error));
  if (!data) return;
  check(name, data.residual.axial_nm.length === body.profile.x_mm.length, "one residual per point");
  const radius: number | null = data.alignment.radius_of_curvature_mm;
  check(name, radius === null || radius !== 0, "radius");
  // The correction target is a complete optimize target.
  const target: Schemas["TargetDto"] = data.correction_target;
  check(name, target.free_piston === true && target.profile !== undefined, "correction target");
}

async function program(name: string): Promise<void> {
  const body = read<Schemas["ProgramRequest"]>(name);
  const { data, error } = await client.POST("/v1/program", { body });
  check(name, error === undefined && data !== undefined, JSON.stringify(error));
  if (!data) return;
  const polishing = data.blocks
    .filter((b) => b.kind === "dwell" || b.kind === "move")
    .reduce((sum, b) => sum + b.duration_s, 0);
  check(name, Math.abs(polishing - data.total_time_s) < 1e-9 * data.total_time_s, "total time");
  const velocity: number | null = data.axes.b.utilisation.velocity;
  check(name, velocity === null || velocity <= 1, "B velocity within its limit");
}

async function calibration(name: string): Promise<void> {
  const body = read<Schemas["CalibrationRequest"]>(name);
  const { data, error } = await client.POST("/v1/calibration", { body });
  check(name, error === undefined && data !== undefined, JSON.stringify(error));
  if (!data) return;
  const k: Schemas["EstimateDto"] | null | undefined = data.parameters.preston_coefficient_m2_per_n;
  const se: number | null | undefined = k?.standard_error;
  check(name, k !== undefined && se !== null && se !== undefined && se > 0, "K with its standard error");
  check(name, data.process.preston_coefficient_m2_per_n === k?.value, "the calibrated process carries K");
  check(name, data.runs.length === body.runs.length, "one fit per run");
}

async function mapAnalysis(name: string): Promise<void> {
  const body = read<Schemas["MapAnalysisRequest"]>(name);
  const { data, error } = await client.POST("/v1/maps/analysis", { body });
  check(name, error === undefined && data !== undefined, JSON.stringify(error));
  if (!data) return;
  const iso: Schemas["IsoDto"] = data.iso_10110;
  // RMSi² = RMSs² + RMSa²: the rotationally symmetric part is a projection.
  const split = Math.hypot(iso.rms_s_nm, iso.rms_a_nm);
  check(name, Math.abs(split - iso.rms_i_nm) <= 1e-9 * iso.rms_i_nm, "RMSi² = RMSs² + RMSa²");
  check(name, data.zernike.terms.length === (body.zernike?.terms ?? 37), "one coefficient per term");
  const target: Schemas["TargetDto"] = data.correction_target;
  check(name, target.profile?.radius_mm.length === data.radial_profile.radius_mm.length, "target");
}

async function mapDifference(name: string): Promise<void> {
  const body = read<Schemas["MapDifferenceRequest"]>(name);
  const { data, error } = await client.POST("/v1/maps/difference", { body });
  check(name, error === undefined && data !== undefined, JSON.stringify(error));
  if (!data) return;
  const nonuniformity: number | null = data.removal.nonuniformity;
  check(name, nonuniformity !== null && data.removal.mean_nm > 0, "a removal with a mean");
  check(name, data.radial_removal.radius_mm.length === data.radial_removal.depth_nm.length, "profile");
}

async function mapRemovalFunction(name: string): Promise<void> {
  const body = read<Schemas["MapRemovalFunctionRequest"]>(name);
  const { data, error } = await client.POST("/v1/maps/removal-function", { body });
  check(name, error === undefined && data !== undefined, JSON.stringify(error));
  if (!data) return;
  const footprint: Schemas["FootprintDto"] = data.footprint;
  check(name, footprint.removal_rate_nm_per_min.length === footprint.y_mm.length, "a row per y");
  const middle = footprint.x_mm[(footprint.x_mm.length - 1) / 2];
  check(name, middle === body.tool_position_mm, "the middle column is the pad centre");
  check(name, data.kinematics === "polar", "a polar request gets a turning part's footprint");
  if (data.kinematics !== "polar") return;
  const average: number[] = data.revolution_average.removal_rate_nm_per_min;
  check(name, average.length === data.revolution_average.radius_mm.length, "the average's profile");
}

async function mapPredict(name: string): Promise<void> {
  const body = read<Schemas["MapPredictRequest"]>(name);
  const { data, error } = await client.POST("/v1/maps/predict", { body });
  check(name, error === undefined && data !== undefined, JSON.stringify(error));
  if (!data) return;
  const rows: (number | null)[][] = data.removal.removal_nm;
  check(name, rows.length === data.removal.y_mm.length, "a row per y");
  check(name, data.kinematics === "polar", "a polar request gets a polar prediction");
  if (data.kinematics !== "polar") return;
  check(name, data.metrics.pixels > 0 && data.non_axisymmetric.rms_nm > 0, "a law's removal is not round");
  check(name, data.total_time_s === body.dwell.dwell_s.reduce((a, b) => a + b, 0), "the plan's time");
}

async function mapOptimize(name: string): Promise<void> {
  const body = read<Schemas["MapOptimizeRequest"]>(name);
  const { data, error } = await client.POST("/v1/maps/optimize", { body });
  check(name, error === undefined && data !== undefined, JSON.stringify(error));
  if (!data) return;
  // The answer is either machine's: `kinematics` tells them apart.
  check(name, data.kinematics === "polar", "a polar request gets a polar plan");
  if (data.kinematics !== "polar") return;
  const metrics: Schemas["CorrectionMetricsDto"] = data.metrics;
  check(name, metrics.after.rms_nm < metrics.before.rms_nm, "the correction lowers the RMS");
  check(name, data.c_law.speed_factors.length === data.dwell.positions_mm.length, "a law row per station");
  check(name, data.harmonic_budget.every((b) => b.amplitude_nm.length === data.max_harmonic), "a budget per harmonic");
}

async function mapProgram(name: string): Promise<void> {
  const body = read<Schemas["MapProgramRequest"]>(name);
  const { data, error } = await client.POST("/v1/maps/program", { body });
  check(name, error === undefined && data !== undefined, JSON.stringify(error));
  if (!data) return;
  check(name, data.kinematics === "polar", "a polar request gets a program with C words");
  if (data.kinematics !== "polar") return;
  const c: Schemas["CAxisReport"] = data.axes.c;
  check(name, c.peak_velocity_deg_per_min > 0 && c.turns !== 0, "C turns");
  const planned = body.dwell.dwell_s.reduce((a, b) => a + b, 0);
  check(name, Math.abs(data.total_time_s - planned) <= 1e-9 * planned, "the plan's time");
  check(name, data.blocks > body.dwell.positions_mm.length, "cut at the sector edges");
}

// An error comes back typed as the problem it is.
async function problem(): Promise<void> {
  const body = read<Schemas["PredictRequest"]>("predict_paper_exp2.json");
  body.process.workpiece_rpm = 0;
  const { data, error, response } = await client.POST("/v1/predict", { body });
  check("problem", data === undefined && response.status === 422, `status ${response.status}`);
  const field: string | null | undefined = error?.field;
  check("problem", field === "process.workpiece_rpm", `field ${field}`);
}

const runners: [string, (name: string) => Promise<void>][] = [
  ["removal_function_", removalFunction],
  ["predict_", predict],
  ["optimize_", optimize],
  ["recommend_", recommend],
  ["eta_sweep_", etaSweep],
  ["measurement_fit_", measurementFit],
  ["program_", program],
  ["calibration_", calibration],
  ["maps_analysis", mapAnalysis],
  ["maps_difference", mapDifference],
  ["maps_removal_function", mapRemovalFunction],
  ["maps_predict", mapPredict],
  ["maps_optimize", mapOptimize],
  ["maps_program", mapProgram],
];
let calls = 0;
for (const name of readdirSync(fixtures).filter((f) => f.endsWith(".json")).sort()) {
  const runner = runners.find(([prefix]) => name.startsWith(prefix));
  if (!runner) throw new Error(`no operation for fixture ${name}`);
  await runner[1](name);
  calls += 1;
}
await problem();
const health = await client.GET("/healthz");
check("healthz", health.data?.status === "ok", JSON.stringify(health.data));
console.log(`typescript client: ${calls} fixtures and a problem through the generated types`);
