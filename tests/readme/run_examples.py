#!/usr/bin/env python3
"""Runs every shell example of README.md against a live service, so the README cannot drift.

    python3 tests/readme/run_examples.py target/release/preston
        [--only LINE ...] [--timeout SECONDS] [--verbose] [--readme FILE]

The examples are read from README.md itself: every ```sh fenced block, indented ones inside
list items too (the fence's indent is taken off its lines). A block that calls `cargo` (the
opening set-up block: it builds, serves and tests) is skipped and named as skipped: the harness
runs against a binary that is already built.

The harness starts the binary itself (`serve` on a free port, its records store in a fresh
directory under /tmp, no drain delay) and runs each block on its own with `bash -euo pipefail`
from the repository root, with a time limit per block (90 s). Before a block runs,
`127.0.0.1:8080` (or `localhost:8080`) in it becomes the harness's service, and any other
`127.0.0.1:PORT` (a block that starts a service of its own) a free port for that block.
`curl` on the blocks' PATH is a wrapper that runs the real curl with `-D` into a file of the
harness's, so the status of every HTTP answer is seen, even when `jq` keeps only part of it.
The service and the blocks get the caller's environment less any PRESTON_* variables.

A block fails (its README line, why, and its output are printed) when
  - it exits non-zero or runs out of time (bash's "line N" is rewritten to the README line);
  - any HTTP answer it got has a status of 400 or more, or is `application/problem+json`;
  - its output holds a problem body (`"type": "urn:preston:problem…"`, `"status": 4xx/5xx`).
Conventions: HTML comments (invisible when the README is rendered) on the lines just before
the fence (blank lines between allowed), one or more, indented like the fence in a list item:
  <!-- readme-test: expect-problem -->       the block deliberately shows an error: it must
                                             get at least one problem answer (and it may)
  <!-- readme-test: expect-output REGEX -->  its output must match REGEX (Python `re`,
                                             searched): a figure the block's comment promises
Several directives may also share one comment, separated by ` ; `. An unknown directive, or a
readme-test comment that is not just before a fence, is an error, so a misspelt or misplaced
one cannot pass silently. Other figures in the blocks' comments are not checked.

After all blocks it fails if `git status` shows a file that is new or changed compared with
before the run, outside target/ (ignored files included, and a changed file's content compared:
an example must write only under /tmp or target/). The service, and anything a block left
running, is killed at the end, on failure too; on failure the blocks' scripts and outputs and
the service's log are kept in the fresh directory, which is named. Plain Python 3, standard
library only.
"""
import argparse
import hashlib
import os
import re
import shutil
import signal
import socket
import stat
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

ROOT = os.path.dirname(os.path.dirname(os.path.dirname(os.path.abspath(__file__))))
README = os.path.join(ROOT, "README.md")
BLOCK_TIMEOUT_S = 90
SERVICE_START_TIMEOUT_S = 30

FENCE_OPEN = re.compile(r"^(?P<indent>[ \t]*)```sh[ \t]*$")
DIRECTIVE = re.compile(r"^[ \t]*<!--[ \t]*readme-test:(?P<body>.*?)-->[ \t]*$")
# A problem body in a block's output: the problem type, or a JSON status of 4xx/5xx.
PROBLEM_IN_OUTPUT = re.compile(r'"type"\s*:\s*"urn:preston:problem|"status"\s*:\s*[45]\d\d\b')
PORT_IN_BLOCK = re.compile(r"\b(127\.0\.0\.1|localhost):(\d{2,5})\b")
README_PORT = 8080


class Block:
    def __init__(self, line, text):
        self.line = line  # README line of the opening fence (1-based)
        self.text = text
        self.expect_problem = False
        self.expect_output = []  # regexes

    def calls_cargo(self):
        return any(re.match(r"\s*cargo\s", line) for line in self.text.splitlines())


def extract_blocks(path):
    """Every ```sh block of the README with its line and directives."""
    name = os.path.basename(path)
    with open(path, encoding="utf-8") as f:
        lines = f.read().split("\n")
    blocks = []
    used = set()  # lines of the directives that belong to a block
    i = 0
    while i < len(lines):
        m = FENCE_OPEN.match(lines[i])
        if not m:
            i += 1
            continue
        indent = m.group("indent")
        start = i
        body = []
        i += 1
        while i < len(lines) and lines[i].strip() != "```":
            line = lines[i]
            if line.startswith(indent):
                line = line[len(indent):]
            elif line.strip():
                sys.exit(f"{name}:{i + 1}: a line less indented than its fence ({start + 1})")
            body.append(line)
            i += 1
        if i == len(lines):
            sys.exit(f"{name}:{start + 1}: the ```sh block is never closed")
        block = Block(start + 1, "\n".join(body) + "\n")
        j = start - 1
        while j >= 0 and not lines[j].strip():
            j -= 1
        while j >= 0 and DIRECTIVE.match(lines[j]):
            for directive in DIRECTIVE.match(lines[j]).group("body").split(" ; "):
                directive = directive.strip()
                if directive == "expect-problem":
                    block.expect_problem = True
                elif directive.startswith("expect-output "):
                    pattern = directive[len("expect-output "):].strip()
                    try:
                        re.compile(pattern)
                    except re.error as e:
                        sys.exit(f"{name}:{j + 1}: expect-output {pattern!r}: {e}")
                    block.expect_output.append(pattern)
                else:
                    sys.exit(f"{name}:{j + 1}: unknown readme-test directive {directive!r}")
            used.add(j)
            j -= 1
        blocks.append(block)
        i += 1
    for k, line in enumerate(lines):
        if k not in used and re.match(r"\s*<!--\s*readme-test", line):
            sys.exit(f"{name}:{k + 1}: a readme-test comment not just before a ```sh fence")
    return blocks


def free_port():
    with socket.socket(socket.AF_INET, socket.SOCK_STREAM) as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def repository_state():
    """What git sees, ignored files included (target/ is free to write): path -> status and
    a digest of the file, so a change to an already-changed file counts too. None outside a
    git work tree."""
    status = subprocess.run(
        ["git", "status", "--porcelain=v1", "-z", "--untracked-files=all", "--ignored=matching"],
        cwd=ROOT, capture_output=True,
    )
    if status.returncode != 0:
        return None
    out = status.stdout.decode()
    state = {}
    entries = out.split("\0")
    k = 0
    while k < len(entries):
        entry = entries[k]
        k += 1
        if not entry:
            continue
        code, path = entry[:2], entry[3:]
        if code[0] in "RC":
            k += 1  # the rename's source follows
        if path == "target/" or path.startswith("target/"):
            continue
        full = os.path.join(ROOT, path)
        if os.path.isfile(full):
            with open(full, "rb") as f:
                digest = hashlib.sha256(f.read()).hexdigest()
        else:
            digest = "(directory)" if os.path.isdir(full) else "(absent)"
        state[path] = (code, digest)
    return state


def write_curl_wrapper(directory, log_dir):
    real = shutil.which("curl")
    if real is None:
        sys.exit("curl is not on PATH (the README's examples use it)")
    wrapper = os.path.join(directory, "curl")
    with open(wrapper, "w") as f:
        f.write(
            "#!/usr/bin/env bash\n"
            "# The README harness's curl: the real one, with the answer's headers dumped so the\n"
            "# harness sees every status. Written by tests/readme/run_examples.py.\n"
            f'headers=$(mktemp "{log_dir}/curl.XXXXXX")\n'
            'printf \'%s\\n\' "$*" > "$headers.args"\n'
            f'exec {real} -D "$headers" "$@"\n'
        )
    os.chmod(wrapper, os.stat(wrapper).st_mode | stat.S_IXUSR | stat.S_IXGRP | stat.S_IXOTH)


def http_answers(log_dir):
    """(curl arguments, last status, content type) of every answer curl got since the last
    call, and clear the log."""
    answers = []
    for name in sorted(os.listdir(log_dir)):
        if not name.startswith("curl.") or name.endswith(".args"):
            continue
        path = os.path.join(log_dir, name)
        with open(path, encoding="latin-1") as f:
            headers = f.read()
        args = ""
        if os.path.exists(path + ".args"):
            with open(path + ".args", encoding="latin-1") as f:
                args = f.read().strip()
            os.remove(path + ".args")
        os.remove(path)
        status, content_type = None, ""
        for line in headers.splitlines():
            m = re.match(r"HTTP/\S+\s+(\d{3})", line)
            if m:
                status, content_type = int(m.group(1)), ""
            elif line.lower().startswith("content-type:"):
                content_type = line.split(":", 1)[1].strip()
        if status is not None:
            answers.append((args, status, content_type))
    return answers


class Service:
    def __init__(self, binary, work, env):
        self.port = free_port()
        self.url = f"http://127.0.0.1:{self.port}"
        self.log_path = os.path.join(work, "service.log")
        self.log = open(self.log_path, "wb")
        self.process = subprocess.Popen(
            [binary, "serve", "--listen", f"127.0.0.1:{self.port}",
             "--database-url", f"sqlite://{work}/records.db", "--drain-delay-ms", "0"],
            cwd=ROOT, env=env, stdout=self.log, stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL,
            start_new_session=True,
        )
        deadline = time.monotonic() + SERVICE_START_TIMEOUT_S
        while True:
            if self.process.poll() is not None:
                raise RuntimeError(
                    f"the service exited with {self.process.returncode}:\n{self.log_tail()}")
            try:
                with urllib.request.urlopen(f"{self.url}/healthz", timeout=1) as answer:
                    if answer.status == 200:
                        return
            except (OSError, urllib.error.URLError):
                pass
            if time.monotonic() > deadline:
                raise RuntimeError(f"the service did not answer /healthz in "
                                   f"{SERVICE_START_TIMEOUT_S} s:\n{self.log_tail()}")
            time.sleep(0.1)

    def log_tail(self, lines=40):
        self.log.flush()
        with open(self.log_path, encoding="utf-8", errors="replace") as f:
            return "".join(f.readlines()[-lines:])

    def stop(self):
        if self.process.poll() is None:
            self.process.terminate()
            try:
                self.process.wait(timeout=10)
            except subprocess.TimeoutExpired:
                self.process.kill()
                self.process.wait()
        self.log.close()


def kill_group(pgid):
    try:
        os.killpg(pgid, signal.SIGKILL)
    except ProcessLookupError:
        pass


def rewrite_ports(text, service_port, ports):
    def replace(m):
        host, port = m.group(1), int(m.group(2))
        if port == README_PORT:
            return f"{host}:{service_port}"
        if port not in ports:
            ports[port] = free_port()
        return f"{host}:{ports[port]}"

    return PORT_IN_BLOCK.sub(replace, text)


def run_block(block, n, service, work, env, timeout, readme_name):
    """Runs one block: its failures (none when it passes), output, time and own ports."""
    ports = {}
    script = rewrite_ports(block.text, service.port, ports)
    script_path = os.path.join(work, f"block-{n:02}.sh")
    with open(script_path, "w") as f:
        f.write(script)
    out_path = os.path.join(work, f"block-{n:02}.out")
    failures = []
    started = time.monotonic()
    with open(out_path, "wb") as out:
        # A process group of its own: what the block leaves running (a service it started in
        # the background) is killed with it, and nothing it leaves holds the harness's pipes.
        process = subprocess.Popen(
            ["bash", "-euo", "pipefail", script_path], cwd=ROOT, env=env, stdout=out,
            stderr=subprocess.STDOUT, stdin=subprocess.DEVNULL, start_new_session=True,
        )
        code = None
        try:
            code = process.wait(timeout=timeout)
        except subprocess.TimeoutExpired:
            failures.append(f"ran out of time ({timeout:g} s)")
        finally:
            kill_group(process.pid)
            process.wait()
    elapsed = time.monotonic() - started
    with open(out_path, encoding="utf-8", errors="replace") as f:
        output = f.read()
    # bash names the script's lines: name the README's instead.
    output = re.sub(re.escape(script_path) + r": line (\d+)",
                    lambda m: f"{readme_name}:{block.line + int(m.group(1))}", output)
    if code not in (None, 0):
        failures.append(f"exited with status {code}")
    problems = 0
    for args, status, content_type in http_answers(os.path.join(work, "curl")):
        if status >= 400 or content_type.startswith("application/problem+json"):
            problems += 1
            if not block.expect_problem:
                kind = content_type or "no content type"
                failures.append(f"HTTP {status} ({kind}) from: curl {args}")
    if PROBLEM_IN_OUTPUT.search(output):
        problems += 1
        if not block.expect_problem:
            failures.append("its output holds a problem+json body")
    if block.expect_problem and problems == 0:
        failures.append("marked expect-problem, but no problem answer came")
    for pattern in block.expect_output:
        if not re.search(pattern, output):
            failures.append(f"its output does not match expect-output {pattern!r}")
    return failures, output, elapsed, ports


def excerpt(output, head=20, tail=30, width=240):
    """A block's output for the log: long lines cut, the middle of a long output left out."""
    lines = output.rstrip("\n").splitlines() or ["(none)"]
    if len(lines) > head + tail + 1:
        left_out = f"… {len(lines) - head - tail} lines left out …"
        lines = lines[:head] + [left_out] + lines[-tail:]
    cut = lambda l: l if len(l) <= width else l[:width] + f" … ({len(l) - width} more characters)"
    return "\n".join(f"    | {cut(l)}" for l in lines)


def interrupt(signum, frame):
    raise KeyboardInterrupt


def main():
    parser = argparse.ArgumentParser(description=__doc__.split("\n\n")[0])
    parser.add_argument("binary", help="the preston binary, e.g. target/release/preston")
    parser.add_argument("--only", type=int, nargs="+", metavar="LINE",
                        help="run only the blocks whose fence is on these README lines")
    parser.add_argument("--timeout", type=float, default=BLOCK_TIMEOUT_S, metavar="SECONDS",
                        help=f"time limit per block (default {BLOCK_TIMEOUT_S})")
    parser.add_argument("--verbose", action="store_true", help="print every block's output")
    parser.add_argument("--readme", default=README,
                        help="another Markdown file (to try the harness itself); its blocks "
                             "run from the repository root all the same")
    options = parser.parse_args()
    binary = os.path.abspath(options.binary)
    if not os.access(binary, os.X_OK):
        sys.exit(f"{options.binary}: not an executable file")
    for tool in ("bash", "git", "jq"):
        if shutil.which(tool) is None:
            sys.exit(f"{tool} is not on PATH (the README's examples need it)")

    blocks = extract_blocks(options.readme)
    readme_name = os.path.relpath(os.path.abspath(options.readme), ROOT)
    if readme_name.startswith(".."):
        readme_name = options.readme
    if options.only:
        unknown = set(options.only) - {b.line for b in blocks}
        if unknown:
            sys.exit(f"no ```sh block opens on {options.readme} line(s) {sorted(unknown)}")
        blocks = [b for b in blocks if b.line in options.only]

    # SIGTERM (a CI timeout) stops the run the way Ctrl-C does, so the service is killed.
    signal.signal(signal.SIGTERM, interrupt)
    before = repository_state()
    work = tempfile.mkdtemp(prefix="preston-readme-", dir="/tmp")
    os.makedirs(os.path.join(work, "curl"))
    os.makedirs(os.path.join(work, "bin"))
    write_curl_wrapper(os.path.join(work, "bin"), os.path.join(work, "curl"))
    # The service and the blocks see no PRESTON_* settings of the caller's (a keys file, say):
    # the README's examples assume none.
    clean = {k: v for k, v in os.environ.items() if not k.startswith("PRESTON_")}
    env = dict(clean, PATH=os.path.join(work, "bin") + os.pathsep + clean.get("PATH", ""))

    failed = []
    ran = skipped = 0
    started = time.monotonic()
    service = None
    try:
        service = Service(binary, work, clean)
        print(f"README examples against {service.url} (records in {work})")
        for n, block in enumerate(blocks, 1):
            first = next((l for l in block.text.splitlines() if l.strip()), "")
            if block.calls_cargo():
                skipped += 1
                print(f"  {readme_name}:{block.line}: skipped (it runs cargo: {first.strip()[:45]})")
                continue
            failures, output, elapsed, ports = run_block(
                block, n, service, work, env, options.timeout, readme_name)
            ran += 1
            verdict = "ok" if not failures else "FAILED"
            print(f"  {readme_name}:{block.line}: {verdict} ({elapsed:.1f} s) {first.strip()[:70]}")
            if ports:
                own = ", ".join(f"{a} as {b}" for a, b in sorted(ports.items()))
                print(f"    (its own ports: {own})")
            if failures or options.verbose:
                for failure in failures:
                    print(f"    - {failure}")
                print(f"    output (all of it in {os.path.join(work, f'block-{n:02}.out')}):")
                print(excerpt(output))
            if failures:
                failed.append(block.line)
            if service.process.poll() is not None:
                print(f"the service exited ({service.process.returncode}) during the block:\n"
                      f"{service.log_tail()}")
                failed.append(block.line)
                break
    except KeyboardInterrupt:
        print("interrupted")
        failed.append("interrupted")
    except RuntimeError as e:
        print(e)
        failed.append("service")
    finally:
        if service is not None:
            service.stop()

    after = repository_state()
    if before is None or after is None:
        print("not a git work tree: whether the examples wrote into the repository is not checked")
        after = before = {}
    changed = sorted(p for p, s in after.items() if before.get(p) != s)
    if changed:
        print("the examples wrote into the repository (only /tmp and target/ are theirs):")
        for path in changed:
            print(f"    {after[path][0]} {path}")
        failed.append("repository")

    print(f"{ran} blocks run, {skipped} skipped, in {time.monotonic() - started:.1f} s")
    if failed:
        names = ", ".join(f"{readme_name}:{f}" if isinstance(f, int) else f for f in failed)
        print(f"README examples FAILED: {names} (scripts, outputs and the service log in {work})")
        sys.exit(1)
    shutil.rmtree(work, ignore_errors=True)
    print("README examples passed")


if __name__ == "__main__":
    main()
