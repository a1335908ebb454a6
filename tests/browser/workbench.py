"""The workbench in a real browser: Debian's chromium, headless, driven over WebDriver
(chromium-driver) with selenium, against the release binary.

    python tests/browser/workbench.py target/release/preston [--screenshots DIR]

It loads the page and finds its first charts drawn from the answers the page came with (no
API call), switches the edge-pressure model, edits the process and reruns, provokes a
field error and finds it next to the field, optimizes a plan and fetches its machine program,
uploads a probe trace and plans its correction, calibrates from the example rings, shows a
part's cycles and its profile's calibrations in the Parts view (records made through the API)
and plans its next cycle, reopens a shared link, checks that nothing was
loaded from another origin and that the console holds no errors but the provoked ones; then,
against a service with API keys, that a missing key is shown at the key field and that the page
works once the key is entered. Exits non-zero on the first failure.
"""

import argparse
import hashlib
import json
import os
import socket
import subprocess
import sys
import tempfile
import time
import urllib.parse
import urllib.request
from pathlib import Path

from selenium import webdriver
from selenium.webdriver.chrome.service import Service
from selenium.webdriver.common.by import By
from selenium.webdriver.common.keys import Keys
from selenium.webdriver.support.ui import Select, WebDriverWait

ROOT = Path(__file__).resolve().parents[2]
TIMEOUT_S = 60


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


class Preston:
    """The release binary on a free loopback port."""

    def __init__(self, binary, *args):
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.log = tempfile.NamedTemporaryFile("w+", suffix=".log", delete=False)
        # A records store of its own (SQLite), never the working directory's.
        self.database = tempfile.mkdtemp(prefix="preston-records-")
        self.proc = subprocess.Popen(
            [binary, "serve", "--listen", f"127.0.0.1:{self.port}", "--drain-delay-ms", "0",
             "--database-url", f"sqlite://{self.database}/records.db", *args],
            stdout=self.log,
            stderr=subprocess.STDOUT,
        )
        for _ in range(200):
            try:
                socket.create_connection(("127.0.0.1", self.port), timeout=0.2).close()
                return
            except OSError:
                time.sleep(0.05)
        sys.exit(f"the service did not start; log: {Path(self.log.name).read_text()}")

    def stop(self):
        self.proc.terminate()
        self.proc.wait(timeout=10)


DOWNLOADS = Path(tempfile.mkdtemp(prefix="preston-downloads-"))


def browser():
    options = webdriver.ChromeOptions()
    options.add_experimental_option("prefs", {
        "download.default_directory": str(DOWNLOADS),
        "download.prompt_for_download": False,
    })
    options.binary_location = os.environ.get("CHROMIUM", "/usr/bin/chromium")
    for arg in ("--headless=new", "--no-sandbox", "--disable-dev-shm-usage", "--disable-gpu",
                "--window-size=1280,800", "--hide-scrollbars"):
        options.add_argument(arg)
    options.set_capability("goog:loggingPrefs", {"browser": "ALL", "performance": "ALL"})
    driver = webdriver.Chrome(options=options, service=Service(
        os.environ.get("CHROMEDRIVER", "/usr/bin/chromedriver")))
    # A 1280 × 800 viewport, whatever the window's own decorations take.
    driver.set_window_size(1280, 800)
    inner = driver.execute_script("return [innerWidth, innerHeight]")
    driver.set_window_size(1280 + 1280 - inner[0], 800 + 800 - inner[1])
    return driver


def check(condition, message):
    if not condition:
        raise AssertionError(message)
    print(f"ok: {message}")


class Page:
    def __init__(self, driver):
        self.d = driver
        self.allowed_console = []  # substrings of console errors this test provoked

    def wait(self, what, predicate):
        try:
            return WebDriverWait(self.d, TIMEOUT_S, poll_frequency=0.1).until(lambda d: predicate())
        except Exception as e:
            problems = [p.text for p in self.d.find_elements(By.CSS_SELECTOR, ".problem") if p.text]
            raise AssertionError(f"timed out waiting for {what}; problems shown: {problems}") from e

    def css(self, selector):
        return self.d.find_elements(By.CSS_SELECTOR, selector)

    def one(self, selector):
        return self.d.find_element(By.CSS_SELECTOR, selector)

    def set(self, element_id, value):
        el = self.one(f"#{element_id}")
        el.clear()
        el.send_keys(str(value))

    def series(self, chart):
        return self.css(f'figure[data-chart="{chart}"] svg path.series')

    def chart_drawn(self, chart, lines=1, points=20):
        paths = self.series(chart)
        return len(paths) >= lines and all(
            p.get_attribute("d").count("L") >= points for p in paths[:lines])

    def painted_pixels(self, chart):
        """The opaque pixels of a heat map's canvas."""
        canvas = self.one(f'figure[data-chart="{chart}"] canvas')
        return self.d.execute_script(
            "const c = arguments[0]; const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
            " let n = 0; for (let i = 3; i < d.length; i += 4) if (d[i] > 0) n++; return n;", canvas)

    def ran(self, view):
        return self.one(f'section[data-view="{view}"]').get_attribute("data-ran")

    def finished(self, view, outcome="ok"):
        """Waits for the view's run to end, then insists on how it ended."""
        self.wait(f"{view} to finish", lambda: self.ran(view) in ("ok", "problem"))
        if self.ran(view) != outcome:
            problems = [p.text for p in self.css(".problem") if p.text]
            raise AssertionError(f"{view} ended with {self.ran(view)}, not {outcome}: {problems}")

    def run_and_wait(self, view, submit, outcome="ok"):
        self.d.execute_script(
            f'document.querySelector(\'section[data-view="{view}"]\').removeAttribute("data-ran")')
        submit()
        self.finished(view, outcome)

    def console_errors(self):
        errors = [e for e in self.d.get_log("browser") if e["level"] == "SEVERE"]
        return [e["message"] for e in errors
                if not any(a in e["message"] for a in self.allowed_console)]

    def text_of(self, selector):
        return " ".join(e.text for e in self.css(selector))

    def screenshot(self, directory, name):
        """The whole view at 1280 px wide (the window grows to the page's height, then back)."""
        if directory:
            path = Path(directory) / f"workbench-{name}.png"
            height = self.d.execute_script("return document.documentElement.scrollHeight")
            size = self.d.get_window_size()
            self.d.set_window_size(size["width"], size["height"] + max(0, height - self.viewport()[1]))
            self.d.save_screenshot(str(path))
            self.d.set_window_size(size["width"], size["height"])
            print(f"screenshot: {path}")

    def viewport(self):
        return self.d.execute_script("return [innerWidth, innerHeight]")


def main_flow(binary, screenshots):
    service = Preston(binary)
    driver = browser()
    page = Page(driver)
    try:
        driver.get(service.url + "/")
        # Paper experiment 1 on load: removal function, prediction, η sweep — drawn from the
        # answers that came with the page, so its first paint shows them (no API call yet).
        page.finished("predict")
        asked = driver.execute_script(
            "return performance.getEntriesByType('resource').map(e => e.name)"
            ".filter(n => n.includes('/v1/'))")
        check(asked == [], f"the first paint needs no API call: its answers came with the page {asked}")
        check(page.text_of('section[data-view="predict"] .status').startswith("Done"),
              "the first view is done, not computing")
        check(page.chart_drawn("removal-function", 3), "removal function: three profiles drawn")
        check(page.chart_drawn("predict", 2), "prediction: now and η = −1 drawn")
        check(page.chart_drawn("eta-sweep", 1, 10), "η sweep drawn")
        predict_fig = page.one('figure[data-chart="predict"]').text
        check("radius r (mm)" in predict_fig and "removal depth (nm)" in predict_fig,
              "prediction axes carry units")
        check("clear aperture 0–40 mm" in predict_fig, "clear aperture marked")
        sweep_fig = page.one('figure[data-chart="eta-sweep"]').text
        check("η window" in sweep_fig and page.css('figure[data-chart="eta-sweep"] rect.band'),
              "η window shaded on the sweep")
        summary = page.text_of('[data-summary="recommend"]')
        check("106.1, 106.1 r/min" in summary, f"η = −1 speeds of paper experiment 1 shown ({summary!r})")
        check("Improvement\nremoved" in summary, f"the nonuniformity η = −1 removes is said so ({summary!r})")
        page.screenshot(screenshots, "predict")
        page.one('figure[data-chart="predict"] a[data-format="csv"]').click()
        table = DOWNLOADS / "preston-predict.csv"
        page.wait("the prediction as CSV", lambda: table.exists() and table.stat().st_size > 0)
        rows = table.read_text().splitlines()
        check(any(r.startswith("radius_mm") for r in rows[:5]) and len(rows) > 200,
              f"the prediction downloads as CSV ({len(rows)} lines)")

        # Edit the process and rerun from the keyboard (Enter in a set-up field).
        before = page.series("predict")[0].get_attribute("d")
        page.set("tool_rpm", 150)
        page.run_and_wait("predict", lambda: page.one("#tool_rpm").send_keys(Keys.ENTER))
        after = page.series("predict")[0].get_attribute("d")
        check(before != after, "a new process gives a new prediction")
        check("tool_rpm=150" in driver.current_url, "the process is in the URL")

        # The edge-pressure model: a rigid pad (linear), its κ shown only then.
        check(not page.one("#pad_moment_share").is_displayed(), "κ hidden under uniform pressure")
        Select(page.one("#pressure_model")).select_by_value("linear")
        check(page.one("#pad_moment_share").is_displayed(), "κ shown for a linear pad")
        page.run_and_wait("predict", lambda: page.one("#tool_rpm").send_keys(Keys.ENTER))
        check("pressure_model=linear" in driver.current_url, "the pressure model is in the URL")
        Select(page.one("#pressure_model")).select_by_value("uniform")
        page.run_and_wait("predict", lambda: page.one("#tool_rpm").send_keys(Keys.ENTER))

        # A field error from the API, shown next to the field it names.
        page.allowed_console.append("422")
        page.set("tool_radius_mm", -5)
        page.run_and_wait("predict", lambda: page.one("#tool_radius_mm").send_keys(Keys.ENTER),
                          outcome="problem")
        error = page.one("#tool_radius_mm-error").text
        check("tool_radius_mm" in page.one('section[data-view="predict"] .problem').text
              and error, f"field error shown next to the tool radius: {error!r}")
        check(page.one("#tool_radius_mm").get_attribute("aria-invalid") == "true",
              "the field is marked invalid")
        page.set("tool_radius_mm", 10)
        page.set("tool_rpm", 200)
        page.run_and_wait("predict", lambda: page.one("#tool_rpm").send_keys(Keys.ENTER))
        check(not page.one("#tool_radius_mm-error").text, "the error clears once the field is fixed")

        # Optimize: plan, charts, machine program download.
        page.one("#tab-optimize").click()
        page.finished("optimize")
        check(page.chart_drawn("optimize-removal", 2), "planned removal and target drawn")
        check(page.chart_drawn("optimize-dwell", 1), "dwell plan drawn")
        page.wait("the program link", lambda: page.css('[data-program="optimize"] a[data-download="program"]'))
        link = page.one('[data-program="optimize"] a[data-download="program"]')
        check(link.get_attribute("download") == "preston-program.ngc"
              and link.get_attribute("href").startswith("blob:"), "program download offered")
        link.click()
        program = DOWNLOADS / "preston-program.ngc"
        page.wait("the downloaded program", lambda: program.exists() and program.stat().st_size > 0)
        gcode = program.read_text()
        check("G93" in gcode and gcode.rstrip().endswith("M2"),
              f"the download is a G-code program ({len(gcode.splitlines())} lines)")
        page.screenshot(screenshots, "optimize")

        # Measure: upload a trace (the fit's OpenAPI example), fit, plan the correction.
        page.one("#tab-measure").click()
        page.one("#example-trace").click()  # sets the design surface of the example
        page.wait("the example trace", lambda: page.one("#trace_csv").get_attribute("value").startswith("x_mm,z_mm"))
        example = json.loads((ROOT / "fixtures/measurement_fit_asphere.json").read_text())
        trace = tempfile.NamedTemporaryFile("w", suffix=".csv", delete=False)
        trace.write("x_mm,z_mm\n" + "".join(
            f"{x},{z}\n" for x, z in zip(example["profile"]["x_mm"], example["profile"]["z_mm"])))
        trace.close()
        page.one("#trace_csv").clear()
        page.one("#trace_file").send_keys(trace.name)
        page.wait("the uploaded trace", lambda: page.one("#trace_csv").get_attribute("value").count("\n") >= 100)
        page.run_and_wait("measure", lambda: page.one('section[data-view="measure"] button[type="submit"]').click())
        check(page.chart_drawn("form-error", 1), "form error drawn")
        check(page.chart_drawn("correction", 2), "correction plan drawn")
        measured = page.text_of('[data-summary="measure"]')
        check("Form error RMS" in measured, f"form error reported ({measured[:80]!r}…)")
        page.wait("the correction program", lambda: page.css('[data-program="measure"] a[data-download="program"]'))
        page.screenshot(screenshots, "measure")

        # Calibrate: the example ring test (the calibration's OpenAPI example) on the plane it
        # was made on; the calibrated process goes into the set-up.
        driver.execute_script(
            "const s = document.getElementById('surface_kind'); s.value = 'plane';"
            " s.dispatchEvent(new Event('change'));")
        page.one("#tab-calibrate").click()
        page.one("#example-rings").click()
        page.wait("the example rings",
                  lambda: page.one("#rings_csv").get_attribute("value").count("\n") >= 150)
        page.run_and_wait("calibrate", lambda: page.one('section[data-view="calibrate"] button[type="submit"]').click())
        check(page.chart_drawn("calibration", 4), "measured and calibrated grooves drawn")
        calibrated = page.text_of('[data-summary="calibrate"]')
        check("Pad radius" in calibrated and "× nominal" in calibrated,
              f"K and the pad radius reported ({calibrated[:80]!r}…)")
        page.one('[data-use="calibrate"] button').click()
        k = float(page.one("#preston_coefficient_m2_per_n").get_attribute("value"))
        check(abs(k / 1.3e-13 - 1) < 0.01, f"the calibrated K is in the set-up ({k})")
        page.screenshot(screenshots, "calibrate")

        # Parts: records made through the API (a profile with a ring calibration, a part, its
        # measurement, a plan and its run, then the next measurement), shown by the Parts view.
        base = service.url

        def call(method, path, body=None):
            request = urllib.request.Request(
                base + path, method=method, headers={"Content-Type": "application/json"},
                data=None if body is None else json.dumps(body).encode())
            with urllib.request.urlopen(request, timeout=120) as response:
                return json.loads(response.read())

        rings = json.loads((ROOT / "fixtures/calibration_rings.json").read_text())
        call("POST", "/v1/process-profiles", {"name": "browser-cell", "process": rings["process"]})
        call("POST", "/v1/process-profiles/browser-cell/calibrations",
             {k: v for k, v in rings.items() if k != "process"})
        part = call("POST", "/v1/parts", {
            "name": "SN-BROWSER-1", "process_profile": "browser-cell", "surface": example["surface"],
            "workpiece_radius_mm": 50, "clear_aperture": example["clear_aperture"]})
        measurement = {k: v for k, v in example.items() if k not in ("surface", "clear_aperture")}
        call("POST", f"/v1/parts/{part['id']}/measurements", measurement)
        plan = call("POST", f"/v1/parts/{part['id']}/plans",
                    {"positions_mm": [i / 2 for i in range(91)]})
        # A run starts after its plan exists: from now on.
        start = time.time() + 1
        stamp = lambda t: time.strftime("%Y-%m-%dT%H:%M:%SZ", time.gmtime(t))
        call("POST", f"/v1/parts/{part['id']}/runs", {
            "plan_id": plan["id"], "started_at": stamp(start),
            "finished_at": stamp(start + 4 * 3600)})
        call("POST", f"/v1/parts/{part['id']}/measurements", measurement)
        page.one("#tab-parts").click()
        page.finished("parts")
        check(page.css('[data-list="parts"] button[data-part]'), "the parts are listed")
        check(len(page.series("convergence")) >= 3, "RMS before, predicted and measured after drawn")
        check(len(page.series("rate")) >= 1, "the profile's calibration history drawn")
        shown = page.text_of('[data-summary="parts"]')
        check("SN-BROWSER-1" in shown and "Cycles 1" in shown.replace("\n", " "),
              f"the part and its cycle summarised ({shown[:100]!r}…)")
        # The part was measured again unchanged: a cycle that removed nothing, said as such.
        check("not determined: removed nothing measurable" in shown and "NaN" not in shown,
              f"a cycle that taught nothing is said so, with no NaN ({shown!r})")
        page.one('[data-use="parts"] button').click()
        page.wait("the next plan", lambda: "Next plan" in page.text_of('[data-summary="parts"]'))
        page.screenshot(screenshots, "parts")

        # Maps: the real Fizeau map (prysm's MetroPro sample) dropped in as its file: the heat
        # map, the 37 Zernike bars, the PSD, the ISO figures and the radial profile, then the
        # axisymmetric correction planned and programmed on the set-up (a plane, from the
        # calibration above), and the polar correction beside it.
        page.one("#tab-maps").click()
        sample = str(ROOT / "fixtures/maps/valid_zygo_dat_file.dat")
        page.one("#map_file").send_keys(sample)
        page.one("#map_after_file").send_keys(sample)  # the same map after: nothing removed
        page.run_and_wait("maps", lambda: page.one('section[data-view="maps"] button[type="submit"]').click())
        heat = page.one('figure[data-chart="map-heat"] canvas')
        painted = driver.execute_script(
            "const c = arguments[0]; const d = c.getContext('2d').getImageData(0, 0, c.width, c.height).data;"
            " let n = 0; for (let i = 3; i < d.length; i += 4) if (d[i] > 0) n++; return n;", heat)
        check(painted > 100_000, f"the heat map is painted ({painted} opaque pixels)")
        check("PV" in heat.get_attribute("aria-label"), "the heat map is titled with PV and RMS")
        bars = page.css('figure[data-chart="map-zernike"] rect[data-term]')
        check(len(bars) == 37, f"37 Zernike bars ({len(bars)})")
        check(page.chart_drawn("map-psd", 1), "the PSD drawn")
        check(page.chart_drawn("map-profile", 1), "the radial profile drawn")
        check(page.chart_drawn("map-correction", 2), "the correction plan drawn")
        check(page.chart_drawn("map-removal", 1), "the removal between the maps drawn")
        mapped = page.text_of('[data-summary="maps"]')
        check("Removed (mean / PV)\n0 / 0 nm" in mapped, f"the same map twice removed nothing ({mapped[-200:]!r})")
        check("ISO 10110-5" in mapped and "RMSa" in mapped.replace("RMSt / RMSi / RMSa", "RMSa"),
              f"the ISO figures reported ({mapped[:120]!r}…)")
        page.wait("the map's correction program", lambda: page.css('[data-program="maps"] a[data-download="program"]'))
        # The polar plan of the same map: its target, dwell and residual as heat maps, the
        # harmonic budget, what stays not round against the radial plan, and its C program.
        for name in ("polar-target", "polar-dwell", "polar-residual"):
            painted = page.painted_pixels(name)
            check(painted > 20_000, f"the {name} heat map is painted ({painted} opaque pixels)")
        budget = page.css('figure[data-chart="polar-budget"] table.budget tbody tr')
        check(len(budget) >= 1, f"the harmonic budget tabled ({len(budget)} bands)")
        shares = page.text_of('figure[data-chart="polar-budget"] table.budget')
        check("share" in shares, f"each band's share of C's modulation tabled ({shares[:80]!r}…)")
        polar = page.text_of('[data-summary="maps-polar"]')
        check("Not round: before → after" in polar and "NaN" not in polar,
              f"the polar plan's figures reported ({polar[:160]!r}…)")
        # At the calibrated K the polar plan runs some 30,000 turns of C: more blocks than one
        # program takes, which the page says instead of asking for it.
        page.wait("the polar program's note", lambda: "more than one program" in page.text_of('[data-program="maps-polar"]'))
        # K 100× higher: some 300 turns, a program the page offers. And the same map on an
        # X-Y machine: the pad spinning in place as the tool, its raster's target, dwell and
        # residual maps, and its X-Y program.
        page.set("preston_coefficient_m2_per_n", "1.3e-11")
        page.one("#map_xy").click()
        page.run_and_wait("maps", lambda: page.one('section[data-view="maps"] button[type="submit"]').click())
        page.wait("the polar program", lambda: page.css('[data-program="maps-polar"] a[data-download="polar-program"]'))
        for name in ("xy-target", "xy-dwell", "xy-residual"):
            painted = page.painted_pixels(name)
            check(painted > 1_000, f"the {name} heat map is painted ({painted} opaque pixels)")
        xy = page.text_of('[data-summary="maps-xy"]')
        check("Residual RMS: before → after" in xy and "NaN" not in xy, f"the X-Y plan's figures reported ({xy[:160]!r}…)")
        page.wait("the X-Y program", lambda: page.css('[data-program="maps-xy"] a[data-download="xy-program"]'))
        page.screenshot(screenshots, "maps")

        # A shared link reopens the study.
        page.one("#tab-optimize").click()
        page.set("target_depth_nm", 250)
        page.run_and_wait("optimize", lambda: page.one("#target_depth_nm").send_keys(Keys.ENTER))
        shared = driver.current_url
        driver.get("about:blank")
        driver.get(shared)
        page.finished("optimize")
        check(page.one("#target_depth_nm").get_attribute("value") == "250"
              and page.one("#tab-optimize").get_attribute("aria-selected") == "true",
              "a shared link restores the inputs and the view")

        # Nothing from elsewhere; no console errors but the provoked 422.
        origins = driver.execute_script(
            "return performance.getEntriesByType('resource').map(e => new URL(e.name).origin)")
        check(all(o == service.url for o in origins), f"every resource from the service ({set(origins)})")
        errors = page.console_errors()
        check(not errors, f"no console errors {errors}")
    finally:
        driver.quit()
        service.stop()


def keyed_flow(binary):
    key = "workbench-test-key-" + os.urandom(8).hex()
    keys = tempfile.NamedTemporaryFile("w", suffix=".keys", delete=False)
    keys.write(f"browser:{hashlib.sha256(key.encode()).hexdigest()}\n")
    keys.close()
    service = Preston(binary, "--api-keys-file", keys.name)
    driver = browser()
    page = Page(driver)
    page.allowed_console.append("401")
    try:
        driver.get(service.url + "/")
        page.finished("predict", outcome="problem")
        check(page.one("#api-key-error").text, "a missing key is shown at the key field")
        page.set("api-key", key)
        page.one("#api-key").send_keys(Keys.TAB)  # 'change' stores it for this tab
        page.run_and_wait("predict", lambda: page.one('section[data-view="predict"] button[type="submit"]').click())
        check(page.chart_drawn("predict", 2), "with the key the page works")
        stored = driver.execute_script("return sessionStorage.getItem('preston-api-key')")
        check(stored == key and key not in driver.current_url, "the key is kept in the session, not the URL")
        errors = page.console_errors()
        check(not errors, f"no console errors but the 401 {errors}")
    finally:
        driver.quit()
        service.stop()


def docs_flow(binary):
    """The interactive docs load from the service alone: every request the browser makes
    (DevTools' network log, so nothing is missed that the page's own API would not list) goes
    to 127.0.0.1, and the page is titled for Preston."""
    service = Preston(binary)
    driver = browser()
    try:
        driver.get_log("performance")  # what the empty tab did before
        driver.get(service.url + "/docs/")
        WebDriverWait(driver, 20).until(
            lambda d: d.find_elements(By.CSS_SELECTOR, ".swagger-ui .info .title"))
        WebDriverWait(driver, 20).until(
            lambda d: d.find_elements(By.CSS_SELECTOR, ".swagger-ui .opblock"))
        time.sleep(1.0)  # a validator badge or font would be asked for by now
        requested = []
        for entry in driver.get_log("performance"):
            message = json.loads(entry["message"])["message"]
            if message.get("method") == "Network.requestWillBeSent":
                requested.append(message["params"]["request"]["url"])
        hosts = {urllib.parse.urlsplit(u).hostname for u in requested
                 if not u.startswith(("data:", "blob:"))}
        print(f"/docs/ requested {len(requested)} URLs from {hosts}")
        check(requested and hosts == {"127.0.0.1"},
              f"every request of /docs/ goes to 127.0.0.1 ({len(requested)} requests, hosts {hosts})")
        check("Preston" in driver.title, f"/docs/ is titled for Preston ({driver.title!r})")
        check(driver.find_elements(By.CSS_SELECTOR, ".swagger-ui .opblock"),
              "/docs/ lists the operations")
    finally:
        driver.quit()
        service.stop()


if __name__ == "__main__":
    parser = argparse.ArgumentParser()
    parser.add_argument("binary")
    parser.add_argument("--screenshots")
    args = parser.parse_args()
    main_flow(args.binary, args.screenshots)
    keyed_flow(args.binary)
    docs_flow(args.binary)
    print("browser test passed")
