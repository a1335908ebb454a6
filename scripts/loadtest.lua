-- wrk script: POST the JSON body in $BODY, count responses by status across threads, and
-- print a summary line the load-test script parses.
--
-- Each VARY gives every request its own process, with a value no other request uses:
-- VARY=pressure replaces pressure_kpa (the same machine and η with a new pressure, as a stream
-- of different jobs on one set-up sends); VARY=speed replaces workpiece_rpm (a new η each
-- time); VARY=geometry replaces tool_radius_mm (a new machine set-up each time).
wrk.method = "POST"
wrk.headers["Content-Type"] = "application/json"
local f = assert(io.open(os.getenv("BODY"), "rb"))
wrk.body = f:read("*a")
f:close()
local vary = os.getenv("VARY") or ""

local threads = {}
local next_id = 0
function setup(thread)
  thread:set("id", next_id)
  next_id = next_id + 1
  table.insert(threads, thread)
end

function init(args)
  counts = {}
  sent = 0
end

function request()
  if vary == "" then
    return wrk.format()
  end
  sent = sent + 1
  local body
  if vary == "pressure" then
    local p = string.format('"pressure_kpa": %.9f', 10 + id * 0.5 + sent * 1e-6)
    body = wrk.body:gsub('"pressure_kpa": *%-?[%d%.]+', p)
  elseif vary == "speed" then
    local rpm = string.format('"workpiece_rpm": %.9f', -(10 + id * 0.5 + sent * 1e-6))
    body = wrk.body:gsub('"workpiece_rpm": *%-?[%d%.]+', rpm)
  else
    local radius = string.format('"tool_radius_mm": %.9f', 10 + id * 0.5 + sent * 1e-6)
    body = wrk.body:gsub('"tool_radius_mm": *%-?[%d%.]+', radius)
  end
  return wrk.format(nil, nil, nil, body)
end

function response(status, headers, body)
  counts[status] = (counts[status] or 0) + 1
end

function done(summary, latency, requests)
  local total = {}
  for _, t in ipairs(threads) do
    for status, n in pairs(t:get("counts")) do
      total[status] = (total[status] or 0) + n
    end
  end
  local parts = {}
  for status, n in pairs(total) do
    table.insert(parts, string.format("%d=%d", status, n))
  end
  table.sort(parts)
  local seconds = summary.duration / 1e6
  io.write(string.format(
    "RESULT requests=%d rps=%.1f p50_ms=%.2f p99_ms=%.2f max_ms=%.2f statuses=%s socket_errors=%d\n",
    summary.requests, summary.requests / seconds,
    latency:percentile(50) / 1000, latency:percentile(99) / 1000, latency.max / 1000,
    table.concat(parts, ","),
    summary.errors.connect + summary.errors.read + summary.errors.write + summary.errors.timeout))
end
