// Preston workbench: the page behind GET /. Plain JavaScript, no library and no build step:
// every number comes from the API, every input is validated by the API (a problem+json error
// is shown next to the input its `field` names), and charts are drawn here from the JSON.
'use strict';

(() => {
  const SVG_NS = 'http://www.w3.org/2000/svg'; // a namespace name, never fetched
  const KEY_STORE = 'preston-api-key';
  const VIEWS = ['predict', 'optimize', 'measure', 'calibrate', 'parts', 'maps'];
  // The API's paths, each written once.
  const API = {
    program: '/v1/program',
    removalFunction: '/v1/removal-function',
    recommend: '/v1/recommend',
    etaSweep: '/v1/studies/eta-sweep',
    predict: '/v1/predict',
    optimize: '/v1/optimize',
    measurementFit: '/v1/measurement/fit',
    calibration: '/v1/calibration',
    mapAnalysis: '/v1/maps/analysis',
    mapDifference: '/v1/maps/difference',
    mapRemovalFunction: '/v1/maps/removal-function',
    mapPredict: '/v1/maps/predict',
    mapOptimize: '/v1/maps/optimize',
    mapProgram: '/v1/maps/program',
    parts: '/v1/parts',
    processProfiles: '/v1/process-profiles',
  };
  const COLOURS = ['#1f77b4', '#d62728', '#2ca02c', '#9467bd', '#ff7f0e'];

  const $ = (selector, root = document) => root.querySelector(selector);
  const $$ = (selector, root = document) => Array.from(root.querySelectorAll(selector));
  const section = (view) => $(`section[data-view="${view}"]`);

  /** An element with attributes and children (strings become text, never HTML). */
  function h(tag, attrs = {}, ...children) {
    const el = document.createElement(tag);
    for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, v);
    for (const c of children) el.append(c);
    return el;
  }

  function svg(tag, attrs = {}, text) {
    const el = document.createElementNS(SVG_NS, tag);
    for (const [k, v] of Object.entries(attrs)) el.setAttribute(k, String(v));
    if (text !== undefined) el.textContent = text;
    return el;
  }

  // ---------------------------------------------------------------- calling the API

  /** A problem+json answer (or a network failure in the same shape). */
  class Problem extends Error {
    constructor(problem) {
      super(problem.detail || problem.title);
      this.problem = problem;
    }
  }

  const calls = { predict: [], optimize: [], measure: [], calibrate: [], parts: [], maps: [] };

  function apiKey() {
    return sessionStorage.getItem(KEY_STORE) || '';
  }

  /** The answers the page came with (the predict view's requests for the default set-up,
   * computed by the service when it served the page), each used once, for an equal request. */
  const firstAnswers = (() => {
    try {
      return JSON.parse(document.getElementById('first-answers').textContent);
    } catch {
      return [];
    }
  })();

  function firstAnswer(path, text) {
    const i = firstAnswers.findIndex((a) => a.path === path && JSON.stringify(a.request) === text);
    return i < 0 ? undefined : firstAnswers.splice(i, 1)[0].response;
  }

  /** POSTs `body` to `path`; JSON in and out unless told otherwise. */
  async function post(view, path, body, { accept = 'application/json', csv = false, query } = {}) {
    const url = path + (query ? `?${new URLSearchParams(query)}` : '');
    const headers = { 'Content-Type': csv ? 'text/csv' : 'application/json', Accept: accept };
    if (apiKey()) headers.Authorization = `Bearer ${apiKey()}`;
    const text = csv ? body : JSON.stringify(body);
    if (accept === 'application/json') record(view, url, headers, text);
    const known = accept === 'application/json' && !csv && !query ? firstAnswer(path, text) : undefined;
    if (known !== undefined) return known;
    const response = await fetched(url, { method: 'POST', headers, body: text });
    return accept === 'application/json' ? response.json() : response.text();
  }

  /** The response to a request, or its problem+json (or a network failure in that shape). */
  async function fetched(url, init) {
    let response;
    try {
      response = await fetch(url, init);
    } catch (e) {
      throw new Problem({ title: 'The service cannot be reached', detail: String(e.message || e) });
    }
    if (!response.ok) {
      let problem;
      try {
        problem = await response.json();
      } catch {
        problem = { title: response.statusText, detail: `HTTP ${response.status}` };
      }
      problem.status = response.status;
      problem.retry_after = response.headers.get('Retry-After');
      throw new Problem(problem);
    }
    return response;
  }

  /** POSTs a file as the body (the map as the instrument wrote it), the other fields in the
   * query; shown as curl with `--data-binary @file`. */
  async function postFile(view, path, file, query, accept = 'application/json') {
    const url = path + (query ? `?${new URLSearchParams(query)}` : '');
    const headers = { 'Content-Type': 'application/octet-stream', Accept: accept };
    if (apiKey()) headers.Authorization = `Bearer ${apiKey()}`;
    if (accept === 'application/json') record(view, url, headers, undefined, file.name);
    const response = await fetched(url, { method: 'POST', headers, body: file });
    return accept === 'application/json' ? response.json() : response.text();
  }

  /** GETs a record (JSON). */
  async function get(view, path) {
    const headers = { Accept: 'application/json' };
    if (apiKey()) headers.Authorization = `Bearer ${apiKey()}`;
    record(view, path, headers, undefined);
    return (await fetched(path, { headers })).json();
  }

  /** Shows each call as the curl command that repeats it (the key stays a variable). */
  function record(view, url, headers, text, file) {
    const method = text === undefined && file === undefined ? 'GET' : 'POST';
    const lines = [`curl -s${method === 'POST' ? ' -X POST' : ''} '${location.origin}${url}'`];
    for (const [k, v] of Object.entries(headers)) {
      lines.push(k === 'Authorization' ? `-H 'Authorization: Bearer $PRESTON_API_KEY'` : `-H '${k}: ${v}'`);
    }
    if (file !== undefined) lines.push(`--data-binary '@${file.replace(/'/g, "'\\''")}'`);
    if (text !== undefined) {
      const shown = text.length > 4000 ? `${text.slice(0, 4000)}… (${text.length} bytes)` : text;
      lines.push(`--data-binary '${shown.replace(/'/g, "'\\''")}'`);
    }
    calls[view].push(lines.join(' \\\n  '));
    $('details.api pre', section(view)).textContent = calls[view].join('\n\n');
  }

  // ---------------------------------------------------------------- reading the inputs

  /** The input's value as the API should see it: a number when it reads as one, the text
   * otherwise (so the API names the field), nothing when empty. */
  function value(id) {
    const text = document.getElementById(id).value.trim();
    if (text === '') return undefined;
    const n = Number(text);
    return Number.isFinite(n) ? n : text;
  }

  function defined(object) {
    return Object.fromEntries(Object.entries(object).filter(([, v]) => v !== undefined));
  }

  function processInput() {
    return defined({
      workpiece_radius_mm: value('workpiece_radius_mm'),
      tool_radius_mm: value('tool_radius_mm'),
      workpiece_rpm: value('workpiece_rpm'),
      tool_rpm: value('tool_rpm'),
      preston_coefficient_m2_per_n: value('preston_coefficient_m2_per_n'),
      pressure_kpa: value('pressure_kpa'),
      ...pressureInput(),
    });
  }

  /** The edge-pressure model, when not the default; κ only where it applies. */
  function pressureInput() {
    const model = $('#pressure_model').value;
    if (model === 'uniform') return {};
    if (model !== 'linear') return { pressure_model: model };
    return { pressure_model: model, pad_moment_share: value('pad_moment_share') };
  }

  function surfaceInput() {
    const kind = $('#surface_kind').value;
    if (kind === 'plane') return { kind };
    const surface = defined({ kind, radius_of_curvature_mm: value('radius_of_curvature_mm') });
    if (kind === 'asphere') {
      Object.assign(surface, defined({ conic_constant: value('conic_constant') }));
      const terms = $('#coefficients').value.split(',').map((t) => t.trim()).filter(Boolean);
      surface.coefficients = terms.map((term) => {
        const [power, coefficient] = term.split(':').map((s) => s.trim());
        const p = Number(power);
        const c = Number(coefficient);
        return {
          power: Number.isFinite(p) ? p : power,
          value: coefficient !== undefined && Number.isFinite(c) ? c : (coefficient ?? null),
        };
      });
    }
    return surface;
  }

  function apertureInput() {
    return defined({ inner_mm: value('aperture_inner_mm'), outer_mm: value('aperture_outer_mm') });
  }

  /** Tool positions 0, h, 2h, … up to the aperture's outer radius plus the tool radius. */
  function positions(stepId, outer) {
    const step = value(stepId);
    // To the aperture's edge plus a tool radius, but on the part.
    const edge = Number(value('workpiece_radius_mm'));
    const aperture = outer ?? Number(value('aperture_outer_mm') ?? edge);
    const end = Math.min(aperture + Number(value('tool_radius_mm')), edge);
    if (typeof step !== 'number' || !(step > 0)) {
      throw fieldProblem(stepId, 'The position step must be a positive number of mm.');
    }
    if (!Number.isFinite(end)) return []; // the API names the radius that is wrong
    const count = Math.floor(end / step + 1e-9) + 1;
    if (count > 100000) throw fieldProblem(stepId, `${count} positions: choose a larger step.`);
    const list = Array.from({ length: count }, (_, i) => Number((i * step).toPrecision(12)));
    if (end - list[list.length - 1] > 1e-9 * end) list.push(Number(end.toPrecision(12)));
    // A free gimbal tips off at the edge itself: its positions stop short of it.
    if ($('#pressure_model').value === 'linear' && Number(value('pad_moment_share')) >= 1
        && list.length > 1 && list[list.length - 1] >= edge) list.pop();
    return list;
  }

  /** A problem this page finds itself, in the API's shape, for an input the API never sees. */
  function fieldProblem(id, detail) {
    return new Problem({ title: 'Invalid input', detail, input: id });
  }

  function parseEtas(text) {
    const t = text.trim();
    const range = t.split(':').map(Number);
    if (range.length === 3 && range.every(Number.isFinite) && range[2] !== 0) {
      const [from, to, step] = range;
      const n = Math.floor((to - from) / step + 1e-9) + 1;
      if (n >= 1 && n <= 1000) return Array.from({ length: n }, (_, i) => Number((from + i * step).toPrecision(12)));
    }
    return t.split(/[\s,]+/).filter(Boolean).map((s) => (Number.isFinite(Number(s)) ? Number(s) : s));
  }

  // ---------------------------------------------------------------- problems next to fields

  function clearProblems(view) {
    const root = section(view);
    $('.problem', root).textContent = '';
    for (const el of $$('[aria-invalid="true"]')) el.removeAttribute('aria-invalid');
    for (const el of $$('.field .error')) el.textContent = '';
    $('#api-key-error').textContent = '';
  }

  /** The input whose data-field is the longest prefix of the problem's field, in this view
   * or the shared set-up. */
  function inputFor(view, field) {
    let best = null;
    for (const el of [...$$('[data-field]', section(view)), ...$$('[data-field]', $('#setup'))]) {
      const f = el.dataset.field;
      const match = field === f || field.startsWith(`${f}.`) || field.startsWith(`${f}[`);
      if (match && (!best || f.length > best.dataset.field.length)) best = el;
    }
    return best;
  }

  function errorSlot(input) {
    const field = input.closest('.field');
    let slot = $('.error', field);
    if (!slot) {
      slot = h('span', { class: 'error', id: `${input.id}-error`, role: 'alert' });
      field.append(slot);
      const described = input.getAttribute('aria-describedby');
      input.setAttribute('aria-describedby', described ? `${described} ${slot.id}` : slot.id);
    }
    return slot;
  }

  function showProblem(view, error) {
    const p = error instanceof Problem ? error.problem : { title: 'Error', detail: String(error) };
    const general = $('.problem', section(view));
    if (p.status === 401) {
      $('#api-key-error').textContent = p.detail;
      $('#api-key').setAttribute('aria-invalid', 'true');
    }
    const input = p.input ? document.getElementById(p.input) : p.field ? inputFor(view, p.field) : null;
    if (input) {
      input.setAttribute('aria-invalid', 'true');
      errorSlot(input).textContent = p.detail;
    }
    const parts = [`${p.title}: ${p.detail}`];
    if (p.field) parts.push(`(field ${p.field}${p.conflicts ? `; in conflict: ${p.conflicts.join(', ')}` : ''})`);
    if (p.retry_after) parts.push(`Retry after ${p.retry_after} s.`);
    if (p.request_id) parts.push(`Request id ${p.request_id}.`);
    general.textContent = parts.join(' ');
  }

  // ---------------------------------------------------------------- charts

  function niceTicks(lo, hi, wanted = 6) {
    const raw = (hi - lo) / wanted;
    const magnitude = 10 ** Math.floor(Math.log10(raw));
    const r = raw / magnitude;
    const step = (r >= 7.5 ? 10 : r >= 3.5 ? 5 : r >= 1.5 ? 2 : 1) * magnitude;
    const ticks = [];
    for (let v = Math.ceil(lo / step) * step; v <= hi + step * 1e-9; v += step) {
      ticks.push(Math.abs(v) < step * 1e-9 ? 0 : Number(v.toPrecision(12)));
    }
    return ticks;
  }

  function extent(values, fromZero) {
    let lo = Math.min(...values);
    let hi = Math.max(...values);
    if (!Number.isFinite(lo) || !Number.isFinite(hi)) return [0, 1];
    if (fromZero) {
      lo = Math.min(lo, 0);
      hi = Math.max(hi, 0);
    }
    if (hi - lo <= 1e-12 * Math.max(Math.abs(hi), Math.abs(lo), 1e-300)) {
      const pad = Math.max(Math.abs(hi), 1) * 0.05;
      return [lo - pad, hi + pad];
    }
    const pad = 0.05 * (hi - lo);
    return [fromZero && lo === 0 ? 0 : lo - pad, hi + pad];
  }

  const label = (v) => String(Number(v.toPrecision(6)));

  /**
   * A line chart: axes titled with their units, a legend, an optional shaded x band (the clear
   * aperture, the η window) and an optional dashed horizontal line (a threshold).
   */
  function lineChart({ title, xLabel, yLabel, series, band, hline, fromZero = true }) {
    const W = 560;
    const H = 330;
    // The top margin holds the legend and, under it, the band's label (out of the curves' way).
    const m = { l: 66, r: 14, t: 42, b: 44 };
    const points = series.flatMap((s) => s.points).filter(([x, y]) => Number.isFinite(x) && Number.isFinite(y));
    const [x0, x1] = extent([...points.map((p) => p[0]), ...(band ? [band.from, band.to] : [])], false);
    const [y0, y1] = extent([...points.map((p) => p[1]), ...(hline ? [hline.y] : [])], fromZero);
    const X = (x) => m.l + ((x - x0) / (x1 - x0)) * (W - m.l - m.r);
    const Y = (y) => H - m.b - ((y - y0) / (y1 - y0)) * (H - m.t - m.b);
    const root = svg('svg', { viewBox: `0 0 ${W} ${H}`, role: 'img', 'aria-label': title });
    root.append(svg('title', {}, title));
    if (band) {
      const bx0 = X(Math.max(band.from, x0));
      const bx1 = X(Math.min(band.to, x1));
      root.append(svg('rect', { class: 'band', x: bx0, y: m.t, width: Math.max(bx1 - bx0, 1), height: H - m.t - m.b }));
      root.append(svg('text', { x: bx0 + 2, y: m.t - 5, class: 'band-label' }, band.label));
    }
    for (const t of niceTicks(x0, x1)) {
      root.append(svg('line', { class: 'grid', x1: X(t), x2: X(t), y1: m.t, y2: H - m.b }));
      root.append(svg('text', { x: X(t), y: H - m.b + 14, 'text-anchor': 'middle' }, label(t)));
    }
    for (const t of niceTicks(y0, y1)) {
      root.append(svg('line', { class: 'grid', x1: m.l, x2: W - m.r, y1: Y(t), y2: Y(t) }));
      root.append(svg('text', { x: m.l - 5, y: Y(t) + 4, 'text-anchor': 'end' }, label(t)));
    }
    root.append(svg('rect', { class: 'axis', x: m.l, y: m.t, width: W - m.l - m.r, height: H - m.t - m.b, fill: 'none' }));
    root.append(svg('text', { class: 'x-label', x: (m.l + W - m.r) / 2, y: H - 8, 'text-anchor': 'middle' }, xLabel));
    root.append(svg('text', {
      class: 'y-label', x: 0, y: 0, 'text-anchor': 'middle',
      transform: `translate(14 ${(m.t + H - m.b) / 2}) rotate(-90)`,
    }, yLabel));
    if (hline) {
      root.append(svg('line', { x1: m.l, x2: W - m.r, y1: Y(hline.y), y2: Y(hline.y), stroke: '#b3261e', 'stroke-dasharray': '5 4' }));
      root.append(svg('text', { x: W - m.r - 4, y: Y(hline.y) - 4, 'text-anchor': 'end' }, hline.label));
    }
    let legendX = m.l;
    series.forEach((s, i) => {
      const colour = s.colour || COLOURS[i % COLOURS.length];
      let d = '';
      let pen = 'M';
      for (const [x, y] of s.points) {
        if (Number.isFinite(x) && Number.isFinite(y)) {
          d += `${pen}${X(x).toFixed(2)} ${Y(y).toFixed(2)}`;
          pen = 'L';
        } else {
          pen = 'M'; // a gap in the data, not a zero
        }
      }
      const path = svg('path', { class: 'series', d, stroke: colour, 'data-series': s.name });
      if (s.dashed) path.setAttribute('stroke-dasharray', '6 4');
      root.append(path);
      if (s.markers) {
        for (const [x, y] of s.points) {
          if (Number.isFinite(x) && Number.isFinite(y)) root.append(svg('circle', { cx: X(x), cy: Y(y), r: 2.5, fill: colour }));
        }
      }
      root.append(svg('line', { x1: legendX, x2: legendX + 18, y1: 14, y2: 14, stroke: colour, 'stroke-width': 2 }));
      const text = svg('text', { x: legendX + 22, y: 18 }, s.name);
      root.append(text);
      legendX += 30 + 6.2 * s.name.length;
    });
    return root;
  }

  function draw(view, name, chart) {
    const plot = $(`figure[data-chart="${name}"] .plot`, section(view));
    plot.replaceChildren(lineChart(chart));
  }

  const zip = (xs, ys) => xs.map((x, i) => [x, ys[i]]);
  const apertureBand = (a) => ({ from: a.inner_mm, to: a.outer_mm, label: `clear aperture ${a.inner_mm}–${a.outer_mm} mm` });

  // ---------------------------------------------------------------- downloads

  function saveText(filename, type, text) {
    const a = h('a', { href: URL.createObjectURL(new Blob([text], { type })), download: filename });
    document.body.append(a);
    a.click();
    a.remove();
  }

  /** A link that asks the API for `type` when clicked (`again(type)`) and saves the answer. */
  function fetchedLink(view, text, filename, type, again, attrs = {}) {
    const a = h('a', { href: '#', ...attrs }, text);
    a.addEventListener('click', async (event) => {
      event.preventDefault();
      try {
        saveText(filename, type, await again(type));
      } catch (e) {
        showProblem(view, e);
      }
    });
    return a;
  }

  /** Download links under a chart: the JSON answer in hand, and CSV/SVG asked of the API on
   * click (`again(accept)` repeats the request with another Accept). */
  function downloads(view, name, response, again) {
    const json = h('a', {
      href: URL.createObjectURL(new Blob([JSON.stringify(response, null, 1)], { type: 'application/json' })),
      download: `preston-${name}.json`,
    }, 'JSON');
    const asked = Object.entries({ csv: 'text/csv', svg: 'image/svg+xml' }).map(([format, type]) => (
      fetchedLink(view, format.toUpperCase(), `preston-${name}.${format}`, type, again, { 'data-format': format })));
    $(`figure[data-chart="${name}"] .downloads`, section(view)).replaceChildren('Download: ', json, ...asked);
  }

  /** `again` for a JSON request. */
  const repeat = (view, path, request) => (accept) => post(view, path, request, { accept });

  // ---------------------------------------------------------------- the machine program

  /** The tool and machine limits of the optimize view (each member only when given). */
  function machineInput() {
    const axis = (name, velocity, acceleration) => defined({
      [velocity]: value(`${name}_max_velocity`),
      ...(acceleration ? { [acceleration]: value(`${name}_max_acceleration`) } : {}),
    });
    const machine = defined({
      x: axis('x', 'max_velocity_mm_per_min', 'max_acceleration_mm_per_s2'),
      z: axis('z', 'max_velocity_mm_per_min', 'max_acceleration_mm_per_s2'),
      b: axis('b', 'max_velocity_deg_per_min'),
    });
    for (const k of Object.keys(machine)) if (!Object.keys(machine[k]).length) delete machine[k];
    const tool = defined({ pivot_length_mm: value('pivot_length_mm') });
    return defined({
      tool: Object.keys(tool).length ? tool : undefined,
      machine: Object.keys(machine).length ? machine : undefined,
    });
  }

  async function program(view, dwell) {
    const box = $(`[data-program="${view}"]`);
    box.replaceChildren(h('p', { class: 'status' }, 'Writing the machine program…'));
    const request = { process: processInput(), surface: surfaceInput(), dwell, ...machineInput() };
    try {
      const again = repeat(view, API.program, request);
      const [p, gcode] = await Promise.all([again('application/json'), again('text/x-gcode')]);
      const link = h('a', {
        href: URL.createObjectURL(new Blob([gcode], { type: 'text/x-gcode' })),
        download: 'preston-program.ngc',
        'data-download': 'program',
      }, 'Download the machine program (G-code, .ngc)');
      const csv = fetchedLink(view, 'blocks as CSV', 'preston-program.csv', 'text/csv', again);
      const skipped = p.skipped_positions.leading + p.skipped_positions.trailing;
      box.replaceChildren(
        h('h3', {}, 'Machine program'),
        h('p', {}, `${p.blocks.length} blocks, ${fmtTime(p.program_time_s)} with approach and retract`
          + `${skipped ? `, ${skipped} zero-dwell end positions left out` : ''}. `, link, ' · ', csv),
        h('pre', { 'aria-label': 'G-code, first lines' }, gcode.split('\n').slice(0, 14).join('\n') + '\n…'),
      );
    } catch (e) {
      box.replaceChildren();
      showProblem(view, e);
    }
  }

  // ---------------------------------------------------------------- summaries

  function fmtTime(s) {
    if (!Number.isFinite(s)) return '–';
    const hours = Math.floor(s / 3600);
    const minutes = Math.floor((s % 3600) / 60);
    return hours ? `${hours} h ${minutes} min (${label(s)} s)` : minutes ? `${minutes} min ${Math.round(s % 60)} s` : `${label(s)} s`;
  }

  const pct = (f) => (f === null || f === undefined ? 'n/a' : `${(100 * f).toPrecision(3)} %`);

  function summary(view, name, items) {
    $(`[data-summary="${name}"]`, section(view)).replaceChildren(
      ...items.map(([term, detail, cls]) => h('div', {}, h('dt', {}, term), h('dd', cls ? { class: cls } : {}, detail))),
    );
  }

  // ---------------------------------------------------------------- the views

  async function runPredict() {
    const view = 'predict';
    const process = processInput();
    const surface = surfaceInput();
    const clear_aperture = apertureInput();
    const depth_nm = value('depth_nm');
    const outer = Number(clear_aperture.outer_mm ?? process.workpiece_radius_mm);
    const rfRequest = {
      process, surface,
      tool_positions_mm: Number.isFinite(outer) ? [0.2, 0.5, 0.85].map((f) => Number((f * outer).toFixed(1))) : [],
    };
    const recommendRequest = defined({ process, surface, clear_aperture, depth_nm });
    const sweepRequest = defined({ process, surface, clear_aperture, depth_nm, etas: parseEtas($('#sweep_etas').value) });
    const [rf, rec, sweep] = await Promise.all([
      post(view, API.removalFunction, rfRequest),
      post(view, API.recommend, recommendRequest),
      post(view, API.etaSweep, sweepRequest),
    ]);
    const r = rec.recommendation;
    const feed = r.equal_dwell.feed;
    const recommended = { ...process, workpiece_rpm: r.workpiece_rpm, tool_rpm: r.tool_rpm };
    const predictRequest = { process, surface, feed, clear_aperture };
    const [now, better] = await Promise.all([
      post(view, API.predict, predictRequest),
      post(view, API.predict, { ...predictRequest, process: recommended }),
    ]);

    draw(view, 'removal-function', {
      title: 'Removal function',
      xLabel: 'radius r (mm)', yLabel: 'removal rate (nm/min)',
      series: rf.profiles.map((p) => ({ name: `tool at ${p.tool_position_mm} mm`, points: zip(rf.radius_mm, p.removal_rate_nm_per_min) })),
    });
    downloads(view, 'removal-function', rf, repeat(view, API.removalFunction, rfRequest));
    // The middle position's footprint at one instant: the 2-D model's own.
    const footprint = $('figure[data-chart="footprint"] .plot', section(view));
    if (rfRequest.tool_positions_mm.length > 1) {
      const fpRequest = { process, surface, tool_position_mm: rfRequest.tool_positions_mm[1], pixel_mm: process.tool_radius_mm / 25 };
      const fp = (await post(view, API.mapRemovalFunction, fpRequest)).footprint;
      // The map's rows as the CSV heatMap reads (x, y, value), header first.
      const rows = fp.y_mm.flatMap((y, i) => fp.x_mm.map((x, j) => `${x},${y},${fp.removal_rate_nm_per_min[i][j]}`));
      footprint.replaceChildren(
        heatMap(['x_mm,y_mm,rate', ...rows].join('\n'), fp.pixel_mm, `pad at ${fpRequest.tool_position_mm} mm, one instant`, 'nm/min'));
    } else {
      footprint.replaceChildren(h('p', {}, 'The footprint is drawn for the middle of three or more tool positions.'));
    }
    const eta = now.eta ?? (process.tool_rpm ? -process.workpiece_rpm / process.tool_rpm : NaN);
    draw(view, 'predict', {
      title: 'Predicted removal, equal dwell',
      xLabel: 'radius r (mm)', yLabel: 'removal depth (nm)',
      series: [
        { name: `now (η = ${label(eta)}), ${pct(now.metrics.nonuniformity)}`, points: zip(now.radius_mm, now.removal_nm) },
        { name: `η = −1, ${pct(better.metrics.nonuniformity)}`, points: zip(better.radius_mm, better.removal_nm) },
      ],
      band: apertureBand(now.clear_aperture),
    });
    downloads(view, 'predict', now, repeat(view, API.predict, predictRequest));
    const w = r.eta_window;
    draw(view, 'eta-sweep', {
      title: 'Equal-dwell nonuniformity against η',
      xLabel: 'η = −workpiece_rpm / tool_rpm', yLabel: 'nonuniformity pv/mean (%)',
      series: [{ name: `tool at ${label(sweep.tool_rpm)} r/min`, points: sweep.points.map((p) => [p.eta, 100 * (p.metrics.nonuniformity ?? NaN)]), markers: true }],
      band: w ? { from: w.low, to: w.high, label: `η window ${label(w.low)} … ${label(w.high)}` } : undefined,
      hline: w ? { y: 100 * w.nonuniformity_threshold, label: `threshold ${pct(w.nonuniformity_threshold)}` } : undefined,
    });
    downloads(view, 'eta-sweep', sweep, repeat(view, API.etaSweep, sweepRequest));
    summary(view, 'recommend', [
      ['η = −1 speeds (workpiece, tool)', `${label(r.workpiece_rpm)}, ${label(r.tool_rpm)} r/min`],
      ['η window', w ? `${label(w.low)} … ${label(w.high)}` : 'none'],
      ['Nonuniformity now', pct(r.current_metrics.nonuniformity)],
      ['Nonuniformity at η = −1', pct(r.metrics.nonuniformity), 'good'],
      ['Improvement', r.nonuniformity_removed ? 'removed' : r.improvement_factor ? `${label(r.improvement_factor)}×` : 'n/a'],
      ['Equal-dwell time', fmtTime(r.equal_dwell.total_time_s)],
    ]);
  }

  /** Optimizes a plan for `target` within `constraints` (none when empty) and draws it. */
  async function plan(view, chart, target, stepId, constraints = {}, aperture = undefined) {
    const process = processInput();
    const surface = surfaceInput();
    const clear_aperture = aperture ?? apertureInput();
    const request = defined({ process, surface, clear_aperture, target, positions_mm: positions(stepId, aperture?.outer_mm), ...machineInput() });
    if (Object.keys(constraints).length) request.constraints = constraints;
    const o = await post(view, API.optimize, request);
    const a = o.clear_aperture;
    const inside = (x) => x >= a.inner_mm && x <= a.outer_mm;
    draw(view, chart, {
      title: 'Planned removal against the target',
      xLabel: 'radius r (mm)', yLabel: 'removal depth (nm)',
      series: [
        { name: 'planned removal', points: zip(o.radius_mm, o.removal_nm) },
        { name: 'target', points: zip(o.radius_mm, o.target_nm).map(([x, y]) => [x, inside(x) ? y : NaN]), dashed: true, colour: '#444' },
      ],
      band: apertureBand(a),
    });
    downloads(view, chart, o, repeat(view, API.optimize, request));
    return o;
  }

  /** What a plan achieved: uniformity for a uniform layer, the residual for a correction. */
  function planSummary(o, uniform) {
    return [
      ['Total dwell', fmtTime(o.total_time_s)],
      uniform
        ? ['Nonuniformity', pct(o.metrics.nonuniformity), 'good']
        : ['Uniform layer added', `${label(o.piston_nm ?? 0)} nm`],
      ['Residual RMS / PV', `${label(o.residual.rms_nm)} / ${label(o.residual.pv_nm)} nm`, uniform ? '' : 'good'],
      ['Solver', `${o.solver.status}, ${o.solver.iterations} iterations, ${label(o.solver.solve_time_ms)} ms`],
      ...o.warnings.map((w) => ['Warning', w.message]),
    ];
  }

  async function runOptimize() {
    const view = 'optimize';
    const constraints = defined({
      min_dwell_s: value('min_dwell_s'),
      max_dwell_s: value('max_dwell_s'),
      max_total_time_s: value('max_total_time_s'),
      max_feed_mm_per_min: value('max_feed_mm_per_min'),
    });
    const target = defined({ uniform_depth_nm: value('target_depth_nm') });
    const o = await plan(view, 'optimize-removal', target, 'position_step_mm', constraints);
    draw(view, 'optimize-dwell', {
      title: 'Dwell plan',
      xLabel: 'tool position (mm)', yLabel: 'dwell (s)',
      series: [{ name: 'dwell per position', points: zip(o.dwell.positions_mm, o.dwell.dwell_s) }],
    });
    summary(view, 'optimize', planSummary(o, true));
    await program(view, o.dwell);
  }

  async function runMeasure() {
    const view = 'measure';
    const surface = surfaceInput();
    const query = defined({
      surface: JSON.stringify(surface),
      clear_aperture: JSON.stringify(apertureInput()),
      probe_tip_radius_mm: $('#probe_tip_radius_mm').value.trim() || undefined,
      robust: $('#robust').value,
    });
    const trace = $('#trace_csv').value;
    const fitAs = (accept) => post(view, API.measurementFit, trace, { csv: true, query, accept });
    const fit = await fitAs('application/json');
    draw(view, 'form-error', {
      title: 'Form error',
      xLabel: 'radius r (mm)', yLabel: 'material to remove along the normal (nm)',
      series: [{ name: 'form error, both sides averaged', points: zip(fit.profile.radius_mm, fit.profile.depth_nm) }],
      band: apertureBand(fit.clear_aperture),
      fromZero: false,
    });
    downloads(view, 'form-error', fit, fitAs);
    const f = fit.form_error;
    const al = fit.alignment;
    const items = [
      ['Form error RMS / PV', `${label(f.rms_nm)} / ${label(f.pv_nm)} nm`],
      ['Asymmetry RMS', f.asymmetry_rms_nm === null ? 'n/a' : `${label(f.asymmetry_rms_nm)} nm`],
      ['Alignment', `x ${label(1000 * al.lateral_offset_mm)} µm, tilt ${label(1e6 * al.tilt_rad)} µrad, piston ${label(1000 * al.piston_mm)} µm`],
      ['Points used', `${f.points} (${fit.solver.ignored_points ?? 0} ignored)`],
    ];
    summary(view, 'measure', items);
    const o = await plan(view, 'correction', fit.correction_target, 'correction_step_mm');
    summary(view, 'measure', [...items, ...planSummary(o, false)]);
    await program(view, o.dwell);
  }

  async function runCalibrate() {
    const view = 'calibrate';
    // The ring tests go as the API's own CSV form, the rest as query parameters.
    const query = defined({
      process: JSON.stringify(processInput()),
      surface: JSON.stringify(surfaceInput()),
      fit: JSON.stringify({
        preston_coefficient: true,
        tool_radius: $('#fit_tool_radius').checked,
        pad_moment_share: $('#fit_pad_moment_share').checked,
      }),
      robust: $('#calibration_robust').value,
    });
    const rings = $('#rings_csv').value;
    const calibrateAs = (accept) => post(view, API.calibration, rings, { csv: true, query, accept });
    const c = await calibrateAs('application/json');
    draw(view, 'calibration', {
      title: 'Measured and predicted removal',
      xLabel: 'radius r (mm)', yLabel: 'removal (nm)',
      series: c.runs.flatMap((r, i) => [
        { name: `ring ${i + 1} measured`, points: zip(r.radius_mm, r.measured_nm) },
        { name: `ring ${i + 1} calibrated`, points: zip(r.radius_mm, r.predicted_nm) },
      ]),
      fromZero: false,
    });
    downloads(view, 'calibration', c, calibrateAs);
    const shown = (e, scale = 1) => (e.standard_error === null
      ? `${label(e.value * scale)} (not determined)`
      : `${label(e.value * scale)} ± ${label(e.standard_error * scale)}`);
    const p = c.parameters;
    const items = [['Removal rate', `${label(c.removal_rate_ratio)} × nominal`]];
    if (p.preston_coefficient_m2_per_n) items.push(['K (1e-13 m²/N)', shown(p.preston_coefficient_m2_per_n, 1e13)]);
    if (p.tool_radius_mm) items.push(['Pad radius (mm)', shown(p.tool_radius_mm)]);
    if (p.pad_moment_share) items.push(['Moment share κ', shown(p.pad_moment_share)]);
    items.push(['Residual RMS per ring', c.runs.map((r) => `${label(r.residual_rms_nm)} nm`).join(', ')]);
    for (const w of c.warnings) items.push(['Warning', w.message]);
    summary(view, 'calibrate', items);
    const use = h('button', { type: 'button' }, 'Use the calibrated process in every view');
    use.addEventListener('click', () => {
      $('#preston_coefficient_m2_per_n').value = c.process.preston_coefficient_m2_per_n;
      $('#tool_radius_mm').value = c.process.tool_radius_mm;
      if (c.process.pad_moment_share !== undefined) $('#pad_moment_share').value = c.process.pad_moment_share;
      saveState(view);
    });
    $('[data-use="calibrate"]').replaceChildren(use);
  }

  /** The OpenAPI document's example calibration, as ring CSV rows. */
  async function loadExampleRings() {
    const spec = await (await fetch('/openapi.json')).json();
    const example = spec.paths[API.calibration].post.requestBody.content['application/json'].example;
    const rows = ['position_mm,duration_s,radius_mm,depth_nm'];
    for (const run of example.runs) {
      run.removal.radius_mm.forEach((r, i) => rows.push(
        `${run.ring.position_mm},${run.ring.duration_s},${r},${run.removal.depth_nm[i]}`));
    }
    $('#rings_csv').value = rows.join('\n');
    $('#fit_tool_radius').checked = Boolean(example.fit && example.fit.tool_radius);
  }

  /** The Parts view: the parts, one part's cycles (convergence) and its next plan, and its
   * process profile's calibration history. */
  async function runParts() {
    const view = 'parts';
    const name = $('#part_name').value.trim();
    const page = await get(view, `${API.parts}?${new URLSearchParams(defined({ limit: 20, name: name || undefined }))}`);
    const list = $('[data-list="parts"]', section(view));
    if (page.items.length === 0) {
      list.replaceChildren(h('p', {}, name ? `There is no part named ${name}.` : 'No parts yet: create them through the API (README, "Parts and cycles").'));
      summary(view, 'parts', []);
      return;
    }
    const part = page.items.find((p) => p.name === name) || page.items[page.items.length - 1];
    list.replaceChildren(h('ul', {}, ...page.items.map((p) => {
      const pick = h('button', { type: 'button', 'data-part': p.id }, p.name);
      pick.addEventListener('click', () => {
        $('#part_name').value = p.name;
        run(view);
      });
      return h('li', p.id === part.id ? { 'aria-current': 'true' } : {}, pick, ` ${p.process_profile}, created ${p.created_at}`);
    })));
    const history = await get(view, `${API.parts}/${encodeURIComponent(part.id)}/history`);
    const profile = await get(view, `${API.processProfiles}/${encodeURIComponent(part.process_profile)}`);
    const cycles = history.cycles.map((c, i) => ({ ...c, n: i + 1 }));
    const points = (key) => cycles.filter((c) => c[key] !== null).map((c) => [c.n, c[key]]);
    draw(view, 'convergence', {
      title: `${part.name}: form error RMS over the clear aperture`,
      xLabel: 'cycle', yLabel: 'RMS (nm)',
      series: [
        { name: 'before', points: points('rms_before_nm'), markers: true },
        { name: 'predicted after', points: points('predicted_rms_after_nm'), markers: true },
        { name: 'measured after', points: points('rms_after_nm'), markers: true },
      ].filter((line) => line.points.length > 0),
    });
    const calibrations = [...profile.calibrations].reverse();
    draw(view, 'rate', {
      title: `${profile.name}: Preston coefficient per calibration`,
      xLabel: 'calibration (oldest first)', yLabel: 'K (1e-13 m²/N)',
      // A cycle's calibration has a run_id; it is learned only when significant (the others
      // are kept as the cycle's evidence and teach nothing).
      series: [
        ['ring tests', (c) => !c.run_id],
        ['learned from production', (c) => c.learned],
        ['not learned (removed nothing measurable)', (c) => c.run_id && !c.learned],
      ].map(([name, kind]) => ({
        name, markers: true,
        points: calibrations.map((c, i) => [i + 1, c.preston_coefficient_m2_per_n * 1e13]).filter((_, i) => kind(calibrations[i])),
      })).filter((line) => line.points.length > 0),
      hline: { y: history.next_process.preston_coefficient_m2_per_n * 1e13, label: 'K the next plan uses' },
      fromZero: false,
    });
    const last = cycles[cycles.length - 1];
    const items = [
      ['Part', `${part.name} (${part.process_profile})`],
      ['Cycles', String(cycles.length)],
      ['K for the next plan (1e-13 m²/N)', `${label(history.next_process.preston_coefficient_m2_per_n * 1e13)} (${profile.preston_coefficient_source})`],
    ];
    if (last && last.convergence_ratio !== null) items.push(['Last convergence (RMS before / after)', label(last.convergence_ratio)]);
    if (last && (last.warnings || []).some((w) => w.code === 'removal_not_significant')) {
      // The cycle taught nothing: its ratio (if any fitted) is noise, not a removal rate.
      items.push(['Last removal ratio (actual / predicted)', 'not determined: removed nothing measurable']);
    } else if (last && last.removal_ratio) {
      const se = last.removal_ratio.standard_error;
      items.push(['Last removal ratio (actual / predicted)', se === null || se === undefined
        ? `${label(last.removal_ratio.value)} (no standard error)`
        : `${label(last.removal_ratio.value)} ± ${label(se)}`]);
    }
    summary(view, 'parts', items);
    const next = h('button', { type: 'button' }, 'Plan the next cycle');
    next.addEventListener('click', async () => {
      clearProblems(view);
      try {
        const edge = part.workpiece_radius_mm - Number(history.next_process.tool_radius_mm) / 2;
        const count = Math.max(2, Math.floor(edge / 0.5) + 1);
        const plan = await post(view, `${API.parts}/${encodeURIComponent(part.id)}/plans`, {
          positions_mm: Array.from({ length: count }, (_, i) => i * 0.5),
        });
        summary(view, 'parts', [...items,
          ['Next plan', `${plan.id}: predicted RMS ${label(plan.predicted_rms_after_nm)} nm, ${label(plan.result.total_time_s)} s`]]);
      } catch (e) {
        showProblem(view, e);
      }
    });
    $('[data-use="parts"]').replaceChildren(next);
  }

  // ---------------------------------------------------------------- maps

  let mapFile;
  let afterFile;

  /** POSTs two map files as multipart/form-data (parts `before` and `after`). */
  async function postFiles(view, path, files, query) {
    const url = path + (query ? `?${new URLSearchParams(query)}` : '');
    const headers = { Accept: 'application/json' };
    if (apiKey()) headers.Authorization = `Bearer ${apiKey()}`;
    const form = new FormData();
    for (const [name, file] of Object.entries(files)) form.append(name, file, file.name);
    const lines = [`curl -s -X POST '${location.origin}${url}'`,
      ...Object.entries(files).map(([name, file]) => `-F '${name}=@${file.name.replace(/'/g, "'\\''")}'`)];
    calls[view].push(lines.join(' \\\n  '));
    $('details.api pre', section(view)).textContent = calls[view].join('\n\n');
    return (await fetched(url, { method: 'POST', headers, body: form })).json();
  }

  /** A perceptual blue–green–yellow ramp (viridis' ends and middle), t in [0, 1]. */
  function ramp(t) {
    const stops = [[68, 1, 84], [59, 82, 139], [33, 145, 140], [94, 201, 98], [253, 231, 37]];
    const x = Math.min(Math.max(t, 0), 1) * (stops.length - 1);
    const i = Math.min(Math.floor(x), stops.length - 2);
    const f = x - i;
    return stops[i].map((c, k) => Math.round(c + f * (stops[i + 1][k] - c)));
  }

  /** A map's pixels (CSV x_mm, y_mm, value) as a heat map: colour bar in `unit`, scale bar
   * in mm, the title above; pixels without data stay transparent. */
  function heatMap(csv, pixelMm, title, unit = 'nm') {
    const rows = csv.trim().split('\n').slice(1).map((l) => l.split(',').map(Number));
    // Extremes by a loop: spreading a map's pixels into Math.min overflows the stack.
    const lo = [Infinity, Infinity, Infinity];
    const hi = [-Infinity, -Infinity, -Infinity];
    for (const r of rows) {
      for (let k = 0; k < 3; k += 1) {
        lo[k] = Math.min(lo[k], r[k]);
        hi[k] = Math.max(hi[k], r[k]);
      }
    }
    const [x0, y0, z0] = lo;
    const [x1, y1, z1] = hi;
    const w = Math.round((x1 - x0) / pixelMm) + 1;
    const hgt = Math.round((y1 - y0) / pixelMm) + 1;
    const scale = Math.max(1, Math.floor(420 / Math.max(w, hgt)));
    const image = new ImageData(w, hgt);
    for (const [x, y, z] of rows) {
      const c = Math.round((x - x0) / pixelMm);
      const r = Math.round((y1 - y) / pixelMm);
      const [R, G, B] = ramp(z1 > z0 ? (z - z0) / (z1 - z0) : 0.5);
      image.data.set([R, G, B, 255], 4 * (r * w + c));
    }
    const margin = { top: 34, left: 10, right: 90, bottom: 44 };
    const canvas = h('canvas', {
      class: 'heat', width: w * scale + margin.left + margin.right, height: hgt * scale + margin.top + margin.bottom,
      role: 'img', 'aria-label': title,
    });
    const ctx = canvas.getContext('2d');
    const tile = h('canvas', { width: w, height: hgt });
    tile.getContext('2d').putImageData(image, 0, 0);
    ctx.imageSmoothingEnabled = false;
    ctx.drawImage(tile, margin.left, margin.top, w * scale, hgt * scale);
    ctx.fillStyle = '#1d2430';
    ctx.font = '13px system-ui, sans-serif';
    ctx.fillText(title, margin.left, 20);
    // Colour bar, nm.
    const barX = margin.left + w * scale + 20;
    for (let i = 0; i < hgt * scale; i += 1) {
      const [R, G, B] = ramp(1 - i / (hgt * scale - 1));
      ctx.fillStyle = `rgb(${R},${G},${B})`;
      ctx.fillRect(barX, margin.top + i, 16, 1);
    }
    ctx.fillStyle = '#1d2430';
    ctx.font = '11px system-ui, sans-serif';
    ctx.fillText(`${label(z1)} ${unit}`, barX + 20, margin.top + 10);
    ctx.fillText(`${label(z0)} ${unit}`, barX + 20, margin.top + hgt * scale);
    // Scale bar: a round length near a quarter of the map's width.
    const quarter = (w * pixelMm) / 4;
    const length = [1, 2, 5, 10, 20, 50, 100, 200, 500].find((l) => l >= quarter / 2) ?? quarter;
    const px = (length / pixelMm) * scale;
    const yBar = margin.top + hgt * scale + 18;
    ctx.fillRect(margin.left, yBar, px, 3);
    ctx.fillText(`${length} mm`, margin.left + px + 6, yBar + 5);
    return canvas;
  }

  /** Zernike coefficients as bars, one per term (index below). */
  function zernikeBars(z) {
    const W = 560;
    const H = 260;
    const m = { top: 20, left: 56, right: 10, bottom: 34 };
    const values = z.terms.map((t) => t.coefficient_nm);
    const top = Math.max(...values.map(Math.abs), 1e-12);
    const root = svg('svg', { viewBox: `0 0 ${W} ${H}`, width: W, height: H, role: 'img', 'aria-label': 'Zernike coefficients' });
    const y = (v) => m.top + ((top - v) / (2 * top)) * (H - m.top - m.bottom);
    const band = (W - m.left - m.right) / values.length;
    root.append(svg('line', { x1: m.left, x2: W - m.right, y1: y(0), y2: y(0), stroke: '#888' }));
    z.terms.forEach((t, i) => {
      const v = t.coefficient_nm;
      const bar = svg('rect', {
        x: m.left + i * band + 1, width: Math.max(band - 2, 1), y: Math.min(y(v), y(0)), height: Math.abs(y(v) - y(0)),
        fill: COLOURS[0], 'data-term': t.index,
      });
      bar.append(svg('title', {}, `${z.ordering} ${t.index} ${t.name} (n ${t.n}, m ${t.m}): ${label(v)} nm`));
      root.append(bar);
      if (values.length <= 40 || i % 5 === 0) {
        root.append(svg('text', { x: m.left + (i + 0.5) * band, y: H - m.bottom + 14, 'text-anchor': 'middle', 'font-size': 9 }, t.index));
      }
    });
    root.append(svg('text', { x: 4, y: y(top) + 4, 'font-size': 10 }, `${label(top)} nm`));
    root.append(svg('text', { x: 4, y: y(-top), 'font-size': 10 }, `${label(-top)} nm`));
    root.append(svg('text', { x: W / 2, y: H - 4, 'text-anchor': 'middle', 'font-size': 11 }, `${z.ordering} index (${z.normalization})`));
    return root;
  }

  async function runMaps() {
    const view = 'maps';
    if (!mapFile) throw fieldProblem('map_file', 'Choose or drop a map file first.');
    const terms = value('map_terms');
    const query = defined({
      pixel_mm: value('map_pixel_mm'),
      zernike: JSON.stringify(defined({ ordering: $('#map_ordering').value, terms })),
      remove_power: $('#map_remove_power').checked ? 'true' : undefined,
    });
    const a = await postFile(view, API.mapAnalysis, mapFile, query);
    const csv = await postFile(view, API.mapAnalysis, mapFile, query, 'text/csv');
    const m = a.metrics;
    $('figure[data-chart="map-heat"] .plot', section(view)).replaceChildren(
      heatMap(csv, a.map.pixel_mm, `${mapFile.name}: PV ${label(m.pv_nm)} nm, RMS ${label(m.rms_nm)} nm`));
    $('figure[data-chart="map-zernike"] .plot', section(view)).replaceChildren(zernikeBars(a.zernike));
    draw(view, 'map-psd', {
      title: `PSD (${a.psd.window} window)`,
      xLabel: 'spatial frequency (1/mm)', yLabel: 'log₁₀ PSD (nm²·mm²)',
      series: [{ name: 'azimuthal average', points: zip(a.psd.frequency_per_mm, a.psd.psd_nm2_mm2.map((p) => (p > 0 ? Math.log10(p) : NaN))) }],
      fromZero: false,
    });
    const profile = a.radial_profile;
    draw(view, 'map-profile', {
      title: 'Rotationally symmetric part about the C axis',
      xLabel: 'radius r (mm)', yLabel: 'material standing proud (nm)',
      series: [{ name: 'radial profile', points: zip(profile.radius_mm, profile.depth_nm) }],
      fromZero: false,
    });
    const iso = a.iso_10110;
    const fr = (v) => label(Number(v.toFixed(3)));
    const items = [
      ['PV / RMS / PVr', `${label(m.pv_nm)} / ${label(m.rms_nm)} / ${label(m.pvr_nm)} nm`],
      [`ISO 10110-5 at ${label(iso.fringe_wavelength_nm)} nm`, `3/${fr(iso.power_fringes)}(${fr(iso.irregularity_fringes)}/${fr(iso.rotationally_symmetric_irregularity_fringes)})`],
      ['RMSt / RMSi / RMSa', `${label(iso.rms_t_nm)} / ${label(iso.rms_i_nm)} / ${label(iso.rms_a_nm)} nm`],
      ['Left by a plan in radius alone', `RMS ${label(a.non_axisymmetric.rms_nm)} nm, PV ${label(a.non_axisymmetric.pv_nm)} nm`],
      ['Map', `${a.map.width_px} × ${a.map.height_px} px of ${label(a.map.pixel_mm)} mm (${a.map.format}), ${a.clear_aperture.pixels} in the aperture`],
      ['Part', `centre (${label(a.alignment.centre_x_px)}, ${label(a.alignment.centre_y_px)}) px, radius ${label(a.alignment.part_radius_mm)} mm${a.alignment.fitted ? ' (fitted)' : ''}`],
      ...a.warnings.map((w) => ['Warning', w.message]),
    ];
    summary(view, 'maps', items);
    const removalFigure = $('figure[data-chart="map-removal"]', section(view));
    removalFigure.hidden = !afterFile;
    if (afterFile) {
      const d = await postFiles(view, API.mapDifference, { before: mapFile, after: afterFile },
        defined({ pixel_mm: query.pixel_mm }));
      const e = d.removal;
      items.push(
        ['Removed (mean / PV)', `${label(e.mean_nm)} / ${label(e.pv_nm)} nm`],
        ['Removal nonuniformity', e.nonuniformity === null ? 'n/a' : pct(e.nonuniformity)],
        ['RMS before → after', `${label(d.before.rms_nm)} → ${label(d.after.rms_nm)} nm`],
        ...d.before.bands.map((b, i) => [`${b.name.replace('_', '-')} band RMS`, `${label(b.rms_nm)} → ${label(d.after.bands[i].rms_nm)} nm`]),
      );
      draw(view, 'map-removal', {
        title: 'What the run removed',
        xLabel: 'radius r (mm)', yLabel: 'removal (nm)',
        series: [{ name: 'radial removal', points: zip(d.radial_removal.radius_mm, d.radial_removal.depth_nm) }],
        fromZero: false,
      });
      summary(view, 'maps', items);
    }
    const outer = profile.radius_mm[profile.radius_mm.length - 1];
    const aperture = { inner_mm: Math.ceil(profile.radius_mm[0] * 1000) / 1000, outer_mm: Math.floor(outer * 1000) / 1000 };
    const o = await plan(view, 'map-correction', a.correction_target, 'map_correction_step_mm', {}, aperture);
    summary(view, 'maps', [...items, ...planSummary(o, false)]);
    await program(view, o.dwell);
    const polar = $('[data-polar="maps"]', section(view));
    polar.hidden = true;
    if ($('#map_polar').checked) {
      await correctMap(view, a, query, aperture);
      polar.hidden = false;
    }
    const xy = $('[data-xy="maps"]', section(view));
    xy.hidden = true;
    if ($('#map_xy').checked) {
      await correctXy(view, csv, a);
      xy.hidden = false;
    }
  }

  /** The most blocks one machine program holds (the API's documented limit). */
  const MAX_PROGRAM_BLOCKS = 1e6;

  /** A map on its grid (rows top first) as the heat map's CSV: x_mm, y_mm, value. */
  function gridCsv(x, y, rows) {
    const lines = ['x_mm,y_mm,value'];
    rows.forEach((row, i) => row.forEach((v, j) => { if (v !== null) lines.push(`${x[j]},${y[i]},${v}`); }));
    return lines.join('\n');
  }

  /** The dwell over (r, θ) on the maps' grid: each pixel within the stations' reach shows
   * the time the pad centre spends over its sector at the nearest station (sector k holds the
   * part-frame angle [2πk/S, 2π(k + 1)/S), counter-clockwise from +x). */
  function dwellCsv(o) {
    const { x_mm: x, y_mm: y } = o.maps;
    const r = o.dwell.positions_mm;
    const sectors = o.c_law.sectors;
    const lines = ['x_mm,y_mm,value'];
    for (const yy of y) {
      for (const xx of x) {
        const rho = Math.hypot(xx, yy);
        if (rho > r[r.length - 1] + 1e-9) continue;
        let i = 0;
        while (i + 1 < r.length && Math.abs(r[i + 1] - rho) < Math.abs(r[i] - rho)) i += 1;
        const theta = (Math.atan2(yy, xx) + 2 * Math.PI) % (2 * Math.PI);
        const k = Math.min(Math.floor((theta / (2 * Math.PI)) * sectors), sectors - 1);
        lines.push(`${xx},${yy},${o.sector_dwell_s[i][k]}`);
      }
    }
    return lines.join('\n');
  }

  /** The harmonic budget as a table: a row per radius band, the share of C's modulation the
   * band asks of all its harmonics at once (red above 1), then a column per harmonic m, each
   * cell the target's amplitude over the most the plan can remove (red where it asks more). */
  function budgetTable(bands, shown) {
    const ms = Array.from({ length: shown }, (_, i) => i + 1);
    const head = h('tr', {}, h('th', {}, 'band (mm)'), h('th', {}, 'share'),
      ...ms.map((m) => h('th', {}, `m = ${m}`)));
    const rows = bands.map((b) => h('tr', {},
      h('th', {}, `${label(b.from_mm)}–${label(b.to_mm)}`),
      h('td', b.modulation_share == null || b.modulation_share > 1 ? { class: 'over' } : {},
        b.modulation_share == null ? 'none' : Number(b.modulation_share.toPrecision(2)).toString()),
      ...ms.map((m) => {
        const target = b.target_amplitude_nm[m - 1];
        const most = b.amplitude_nm[m - 1];
        const short = (v) => Number(v.toPrecision(3));
        return h('td', target > most ? { class: 'over' } : {}, `${short(target)} / ${short(most)}`);
      })));
    return h('table', { class: 'budget', 'aria-label': 'Harmonic budget' }, h('thead', {}, head), h('tbody', {}, ...rows));
  }

  /** The polar correction of the map (API.mapOptimize on the file itself): its target, dwell
   * and residual maps, its harmonic budget, and its program (API.mapProgram). */
  async function correctMap(view, a, query, aperture) {
    const { tool, machine: axes } = machineInput();
    const machine = { kinematics: 'polar', ...(axes ?? {}) };
    const process = processInput();
    const surface = surfaceInput();
    const request = defined({
      process: JSON.stringify(process),
      surface: surface ? JSON.stringify(surface) : undefined,
      positions_mm: JSON.stringify(positions('map_correction_step_mm', aperture.outer_mm)),
      clear_aperture: JSON.stringify(aperture),
      alignment: JSON.stringify({ centre_x_px: a.alignment.centre_x_px, centre_y_px: a.alignment.centre_y_px,
        part_radius_mm: a.alignment.part_radius_mm }),
      pixel_mm: query.pixel_mm,
      machine: JSON.stringify(machine),
      c_law: JSON.stringify(defined({ sectors: value('map_sectors') })),
      // The plan's own model: a long plan's exact map is more work than one request may take.
      removal_model: 'harmonic',
    });
    const o = await postFile(view, API.mapOptimize, mapFile, request);
    const { x_mm: x, y_mm: y, pixel_mm: px } = o.maps;
    const m = o.metrics;
    const plot = (name) => $(`figure[data-chart="${name}"] .plot`, section(view));
    plot('polar-target').replaceChildren(heatMap(gridCsv(x, y, o.maps.target_nm), px,
      `Target: RMS ${label(m.before.rms_nm)} nm, not round ${label(m.non_axisymmetric_before.rms_nm)} nm`));
    plot('polar-dwell').replaceChildren(heatMap(dwellCsv(o), px,
      `Dwell: ${o.c_law.sectors} sectors, ${fmtTime(o.total_time_s)} in all`, 's'));
    plot('polar-residual').replaceChildren(heatMap(gridCsv(x, y, o.maps.residual_nm), px,
      `Residual: RMS ${label(m.after.rms_nm)} nm, not round ${label(m.non_axisymmetric_after.rms_nm)} nm`));
    const shown = Math.min(o.max_harmonic, 12);
    plot('polar-budget').replaceChildren(budgetTable(o.harmonic_budget, shown),
      ...(o.max_harmonic > shown ? [h('p', {}, `m = 1 to ${shown} of the ${o.max_harmonic} corrected.`)] : []));
    summary(view, 'maps-polar', [
      ['Residual RMS: polar / radial plan', `${label(m.after.rms_nm)} / ${label(m.radial_plan_after.rms_nm)} nm`, 'good'],
      ['Not round: before → after', `${label(m.non_axisymmetric_before.rms_nm)} → ${label(m.non_axisymmetric_after.rms_nm)} nm`, 'good'],
      ['Total dwell: polar / radial plan', `${fmtTime(o.total_time_s)} / ${fmtTime(m.radial_plan_time_s)}`],
      ['Harmonics corrected', `m = 1 to ${o.max_harmonic}, ${o.c_law.sectors} sectors a turn`],
      ['C peaks', `${label(o.c_peaks.velocity_deg_per_min)} deg/min, ${label(o.c_peaks.acceleration_deg_per_s2)} deg/s²`],
      ['Uniform layer added', `${label(o.piston_nm)} nm`],
      ...o.warnings.map((w) => ['Warning', w.message]),
    ]);
    const box = $('[data-program="maps-polar"]', section(view));
    if (o.blocks > MAX_PROGRAM_BLOCKS) {
      box.replaceChildren(h('h3', {}, 'Polar machine program'), h('p', {},
        `The plan runs C through ${label(o.blocks)} blocks, more than one program holds `
        + `(${label(MAX_PROGRAM_BLOCKS)}): fewer sectors, a larger K or pressure, or a smaller `
        + 'correction per plan.'));
      return;
    }
    await mapProgramBox(view, box, { process, surface, dwell: o.dwell, c_law: o.c_law, machine, tool },
      'Polar', 'preston-polar-program.ngc');
  }

  /** A map plan's program (API.mapProgram) in the box `box`: its summary, its G-code's first
   * lines and a download; `kind` names it ('Polar' or 'X-Y'), `file` the download's name. */
  async function mapProgramBox(view, box, request, kind, file) {
    const slug = kind === 'Polar' ? 'polar' : 'xy';
    box.replaceChildren(h('p', { class: 'status' }, `Writing the ${kind} program…`));
    try {
      const again = repeat(view, API.mapProgram, defined(request));
      const [p, gcode] = await Promise.all([again('application/json'), again('text/x-gcode')]);
      const link = h('a', {
        href: URL.createObjectURL(new Blob([gcode], { type: 'text/x-gcode' })),
        download: file,
        'data-download': `${slug}-program`,
      }, `Download the ${kind} program (G-code${kind === 'Polar' ? ' with C words' : ''}, .ngc)`);
      box.replaceChildren(
        h('h3', {}, `${kind} machine program`),
        h('p', {}, `${p.blocks} blocks, ${fmtTime(p.program_time_s)} with approach and retract. `, link),
        h('pre', { 'aria-label': `${kind} G-code, first lines` }, gcode.split('\n').slice(0, 14).join('\n') + '\n…'),
      );
    } catch (e) {
      box.replaceChildren();
      showProblem(view, e);
    }
  }

  /** The analysis CSV's pixels (x_mm, y_mm, height) back on their grid, rows top first, null
   * where the aperture has no pixel: the map as API.mapOptimize takes it as JSON. */
  function csvGrid(csv, pixelMm) {
    const points = csv.trim().split('\n').slice(1).map((line) => line.split(',').map(Number));
    // Loops, not Math.min(...xs): a map's pixels overflow the call stack as arguments.
    let [x0, x1, y0, y1] = [Infinity, -Infinity, -Infinity, Infinity];
    for (const [x, y] of points) {
      x0 = Math.min(x0, x); x1 = Math.max(x1, x);
      y0 = Math.max(y0, y); y1 = Math.min(y1, y);
    }
    const width = Math.round((x1 - x0) / pixelMm) + 1;
    const height = Math.round((y0 - y1) / pixelMm) + 1;
    const rows = Array.from({ length: height }, () => new Array(width).fill(null));
    for (const [x, y, v] of points) rows[Math.round((y0 - y) / pixelMm)][Math.round((x - x0) / pixelMm)] = v;
    return { heights_nm: rows, pixel_mm: pixelMm };
  }

  /** The dwell points as a heat map's CSV: each point's dwell on the pixel it sits on. */
  function pointsCsv(dwell) {
    return ['x_mm,y_mm,value', ...dwell.points_mm.map(([x, y], k) => `${x},${y},${dwell.dwell_s[k]}`)].join('\n');
  }

  /** The map corrected on an X-Y machine (API.mapOptimize, cartesian) with the process's pad
   * spinning in place on the part standing still as the tool (API.mapRemovalFunction), its
   * target, dwell and residual maps, and its program (API.mapProgram). */
  async function correctXy(view, csv, a) {
    const { machine: axes } = machineInput();
    // Y as the page's X: the page states one table axis's limits.
    const machine = { kinematics: 'cartesian', ...(axes?.x ? { x: axes.x, y: axes.x } : {}) };
    const process = { ...processInput(), workpiece_rpm: 0 };
    const pad = await post(view, API.mapRemovalFunction, {
      process, machine: { kinematics: 'cartesian' },
      pixel_mm: process.tool_radius_mm / 25,
    });
    const o = await post(view, API.mapOptimize, { machine, influence: pad.influence, map: csvGrid(csv, a.map.pixel_mm) });
    const { x_mm: x, y_mm: y, pixel_mm: px } = o.maps;
    const m = o.metrics;
    const plot = (name) => $(`figure[data-chart="${name}"] .plot`, section(view));
    plot('xy-target').replaceChildren(heatMap(gridCsv(x, y, o.maps.target_nm), px,
      `Target: RMS ${label(m.before.rms_nm)} nm (piston and tilt removed)`));
    plot('xy-dwell').replaceChildren(heatMap(pointsCsv(o.dwell), o.dwell_pitch_mm,
      `Dwell: ${o.dwell.dwell_s.length} points ${label(o.dwell_pitch_mm)} mm apart, ${fmtTime(o.total_time_s)} in all`, 's'));
    plot('xy-residual').replaceChildren(heatMap(gridCsv(x, y, o.maps.residual_nm), px,
      `Residual: RMS ${label(m.after.rms_nm)} nm (piston and tilt removed)`));
    summary(view, 'maps-xy', [
      ['Residual RMS: before → after', `${label(m.before.rms_nm)} → ${label(m.after.rms_nm)} nm`, 'good'],
      ['Total dwell', fmtTime(o.total_time_s)],
      ['Pad peak rate, still part', `${label(pad.footprint.peak_removal_rate_nm_per_min)} nm/min`],
      ['X / Y peaks', `${label(o.axes.x.velocity_mm_per_min)} / ${label(o.axes.y.velocity_mm_per_min)} mm/min, `
        + `${label(o.axes.x.acceleration_mm_per_s2)} / ${label(o.axes.y.acceleration_mm_per_s2)} mm/s²`],
      ['Solver', `${o.solver.converged ? 'converged' : 'stopped'} after ${label(o.solver.products)} products`],
      ...o.warnings.map((w) => ['Warning', w.message]),
    ]);
    await mapProgramBox(view, $('[data-program="maps-xy"]', section(view)),
      { machine, dwell: o.dwell, tool_rpm: process.tool_rpm }, 'X-Y', 'preston-xy-program.ngc');
  }

  const RUNS = { predict: runPredict, optimize: runOptimize, measure: runMeasure, calibrate: runCalibrate, parts: runParts, maps: runMaps };

  /** One pass of a view: 'ok' or 'problem' (shown). */
  async function pass(view) {
    const root = section(view);
    const status = $('.status', root);
    clearProblems(view);
    calls[view] = [];
    saveState(view);
    root.dataset.setup = setupStamp();
    status.textContent = 'Computing…';
    try {
      await RUNS[view]();
      status.textContent = `Done at ${new Date().toLocaleTimeString()}.`;
      return 'ok';
    } catch (e) {
      status.textContent = '';
      showProblem(view, e);
      return 'problem';
    }
  }

  const running = {};

  /** Runs a view; asked again while running, it runs once more afterwards with the inputs as
   * they are then, so results are never older than the last request. */
  async function run(view) {
    if (running[view]) {
      running[view] = 'again';
      return;
    }
    const root = section(view);
    root.setAttribute('aria-busy', 'true');
    let outcome;
    do {
      running[view] = true;
      outcome = await pass(view);
    } while (running[view] === 'again');
    running[view] = false;
    root.removeAttribute('aria-busy');
    root.dataset.ran = outcome;
  }

  // ---------------------------------------------------------------- the example trace

  /** The OpenAPI document's example request for the fit, as CSV and surface settings. */
  async function loadExampleTrace() {
    const spec = await (await fetch('/openapi.json')).json();
    const example = spec.paths[API.measurementFit].post.requestBody.content['application/json'].example;
    const { x_mm, z_mm } = example.profile;
    $('#trace_csv').value = ['x_mm,z_mm', ...x_mm.map((x, i) => `${x},${z_mm[i]}`)].join('\n');
    const s = example.surface || { kind: 'plane' };
    $('#surface_kind').value = s.kind;
    if (s.radius_of_curvature_mm !== undefined) $('#radius_of_curvature_mm').value = s.radius_of_curvature_mm;
    $('#conic_constant').value = s.conic_constant ?? 0;
    $('#coefficients').value = (s.coefficients || []).map((c) => `${c.power}:${c.value}`).join(', ');
    if (example.probe_tip_radius_mm !== undefined) $('#probe_tip_radius_mm').value = example.probe_tip_radius_mm;
    if (example.robust) $('#robust').value = example.robust;
    showApplicableFields();
  }

  // ---------------------------------------------------------------- state in the URL

  /** The shared set-up as one string: a view whose last run used another is out of date. */
  function setupStamp() {
    return $$('input, select', $('#setup')).map((el) => el.value).join('\u0000');
  }

  function namedInputs() {
    return $$('input[name], select[name]');
  }

  function saveState(view) {
    const params = new URLSearchParams({ view });
    for (const el of namedInputs()) params.set(el.name, el.value);
    history.replaceState(null, '', `#${params}`);
  }

  function loadState() {
    const params = new URLSearchParams(location.hash.slice(1));
    for (const el of namedInputs()) {
      if (params.has(el.name)) el.value = params.get(el.name);
    }
    const view = params.get('view');
    return VIEWS.includes(view) ? view : 'predict';
  }

  /** Shows the inputs that apply: a curved surface's, an asphere's, a linear pad's κ. */
  function showApplicableFields() {
    const kind = $('#surface_kind').value;
    for (const el of $$('.curved')) el.hidden = kind === 'plane';
    for (const el of $$('.aspheric')) el.hidden = kind !== 'asphere';
    for (const el of $$('.linear')) el.hidden = $('#pressure_model').value !== 'linear';
  }

  function select(view, focus = false) {
    for (const v of VIEWS) {
      const tab = $(`#tab-${v}`);
      tab.setAttribute('aria-selected', String(v === view));
      tab.tabIndex = v === view ? 0 : -1;
      section(v).hidden = v !== view;
    }
    if (focus) $(`#tab-${view}`).focus();
    saveState(view);
  }

  function start() {
    const view = loadState();
    showApplicableFields();
    $('#surface_kind').addEventListener('change', showApplicableFields);
    $('#pressure_model').addEventListener('change', showApplicableFields);
    const key = $('#api-key');
    key.value = apiKey();
    key.addEventListener('change', () => {
      if (key.value) sessionStorage.setItem(KEY_STORE, key.value);
      else sessionStorage.removeItem(KEY_STORE);
    });
    for (const tab of $$('[role="tab"]')) {
      tab.addEventListener('click', () => {
        const view = tab.dataset.view;
        select(view);
        // Rerun a view whose results are from another set-up; measure and calibrate wait for
        // their data.
        const shown = section(view);
        const ranBefore = shown.dataset.setup !== undefined;
        const waits = view === 'measure' || view === 'calibrate' || view === 'maps';
        if ((!waits || ranBefore) && shown.dataset.setup !== setupStamp()) run(view);
      });
      tab.addEventListener('keydown', (event) => {
        const step = { ArrowRight: 1, ArrowLeft: -1 }[event.key];
        if (!step) return;
        const next = VIEWS[(VIEWS.indexOf(tab.dataset.view) + step + VIEWS.length) % VIEWS.length];
        select(next, true);
      });
    }
    for (const form of $$('form[data-run]')) {
      form.addEventListener('submit', (event) => {
        event.preventDefault();
        run(form.dataset.run);
      });
    }
    // Enter in a set-up field reruns the view on show.
    $('#setup').addEventListener('submit', (event) => {
      event.preventDefault();
      const shown = VIEWS.find((v) => !section(v).hidden);
      run(shown);
    });
    $('#example-trace').addEventListener('click', () => loadExampleTrace().catch((e) => showProblem('measure', e)));
    $('#trace_file').addEventListener('change', async (event) => {
      const file = event.target.files[0];
      if (file) $('#trace_csv').value = await file.text();
    });
    $('#example-rings').addEventListener('click', () => loadExampleRings().catch((e) => showProblem('calibrate', e)));
    $('#rings_file').addEventListener('change', async (event) => {
      const file = event.target.files[0];
      if (file) $('#rings_csv').value = await file.text();
    });
    const drop = $('#map_drop');
    $('#map_file').addEventListener('change', (event) => {
      mapFile = event.target.files[0];
    });
    $('#map_after_file').addEventListener('change', (event) => {
      afterFile = event.target.files[0];
    });
    drop.addEventListener('dragover', (event) => {
      event.preventDefault();
      drop.classList.add('over');
    });
    drop.addEventListener('dragleave', () => drop.classList.remove('over'));
    drop.addEventListener('drop', (event) => {
      event.preventDefault();
      drop.classList.remove('over');
      mapFile = event.dataTransfer.files[0];
      if (mapFile) run('maps');
    });
    select(view);
    if (view !== 'measure' && view !== 'calibrate' && view !== 'maps') run(view);
  }

  start();
})();
