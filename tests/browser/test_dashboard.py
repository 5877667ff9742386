#!/usr/bin/env python3
"""The master's dashboard in a real browser (docs/dashboard.md): headless Chromium driven by
chromedriver over the W3C WebDriver protocol, spoken with the standard library only (urllib
and json), against a farm of `prismfarm master --http` and one worker on this host.

Without a token the page shows how many jobs there are and how to sign in, and no job's name
(docs/security.md); signed in with the administrator's token it loads the job list, watches a
job's progressive preview change between two passes; after "Forget" the job page asks to sign
in again and an action without a token is refused; signed in again it cancels the job through
the page and sees the job cancelled and its worker stop. A screenshot of the job page goes to
BUILD/dashboard.png (and to docs/dashboard.png with PRISMFARM_UPDATE_SCREENSHOT=1).

Exit 0: passed; 1: failed (with what); 77: skipped, only when Chromium or chromedriver is
missing or cannot start (ctest SKIP_RETURN_CODE): they are test packages, which
`deploy/install-deps.sh --test` installs and a plain install does not. PRISMFARM_REQUIRE_BROWSER=1
makes a skip a failure (CI sets it: there it must run). Every wait has a generous deadline and no
assertion is about time."""

import base64
import json
import os
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import time
import urllib.error
import urllib.request

SKIP = 77
DEADLINE_S = 240  # any one wait; a passing run needs a small fraction of it
CHROMIUM = os.environ.get("PRISMFARM_CHROMIUM", "/usr/bin/chromium")
CHROMEDRIVER = os.environ.get("PRISMFARM_CHROMEDRIVER", "/usr/bin/chromedriver")


def skip(why):
    if os.environ.get("PRISMFARM_REQUIRE_BROWSER") == "1":
        print("test_dashboard: FAILED: cannot run, and PRISMFARM_REQUIRE_BROWSER=1: " + why,
              flush=True)
        sys.exit(1)
    print("test_dashboard: SKIPPED: " + why, flush=True)
    sys.exit(SKIP)


def fail(why):
    raise AssertionError(why)


def wait_for(what, probe, deadline=DEADLINE_S, every=0.2):
    """probe() until it returns something true; fails naming what after the deadline."""
    end = time.monotonic() + deadline
    last = None
    while time.monotonic() < end:
        try:
            got = probe()
            if got:
                return got
        except Exception as e:  # the page or the farm may be between two states
            last = e
        time.sleep(every)
    fail("waited %d s for %s%s" % (deadline, what, " (last error: %s)" % last if last else ""))


def free_port():
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def http_json(url, method="GET", body=None, headers=None):
    req = urllib.request.Request(url, method=method, data=body, headers=headers or {})
    try:
        with urllib.request.urlopen(req, timeout=30) as r:
            return r.status, json.loads(r.read() or b"null")
    except urllib.error.HTTPError as e:
        return e.code, json.loads(e.read() or b"null")


class WebDriver:
    """The few W3C WebDriver commands the test needs."""

    def __init__(self, port):
        self.base = "http://127.0.0.1:%d" % port
        self.session = None

    def call(self, method, path, body=None):
        data = json.dumps(body).encode() if body is not None else None
        req = urllib.request.Request(self.base + path, method=method, data=data,
                                     headers={"Content-Type": "application/json"})
        try:
            with urllib.request.urlopen(req, timeout=120) as r:
                return json.loads(r.read())["value"]
        except urllib.error.HTTPError as e:
            answer = json.loads(e.read() or b"{}").get("value", {})
            raise RuntimeError("WebDriver %s %s: %s: %s" % (method, path, answer.get("error"),
                                                            answer.get("message", "")[:300]))

    def start(self):
        caps = {"capabilities": {"alwaysMatch": {
            "browserName": "chrome",
            "goog:chromeOptions": {
                "binary": CHROMIUM,
                # Root in a container: no sandbox; no GPU, no /dev/shm of any size needed.
                "args": ["--headless=new", "--no-sandbox", "--disable-gpu",
                         "--disable-dev-shm-usage", "--window-size=1280,1500",
                         "--no-first-run", "--no-default-browser-check"]}}}}
        self.session = self.call("POST", "/session", caps)["sessionId"]

    def s(self, path):
        return "/session/%s%s" % (self.session, path)

    def get(self, url):
        self.call("POST", self.s("/url"), {"url": url})

    def js(self, script, *args):
        return self.call("POST", self.s("/execute/sync"), {"script": script, "args": list(args)})

    def js_async(self, script, *args):
        return self.call("POST", self.s("/execute/async"), {"script": script, "args": list(args)})

    def find(self, css):
        e = self.call("POST", self.s("/element"), {"using": "css selector", "value": css})
        return list(e.values())[0]

    def click(self, css):
        # The dashboard redraws its tables on every poll, so an element found a moment ago may
        # be replaced before the click lands; a stale reference means no click happened, so
        # finding it again and retrying is safe.
        for attempt in range(20):
            try:
                self.call("POST", self.s("/element/%s/click" % self.find(css)), {})
                return
            except RuntimeError as e:
                if "stale element" not in str(e) or attempt == 19:
                    raise
                time.sleep(0.1)

    def type(self, css, text):
        self.call("POST", self.s("/element/%s/value" % self.find(css)), {"text": text})

    def text(self, css):
        return self.call("GET", self.s("/element/%s/text" % self.find(css)))

    def accept_alert(self):
        self.call("POST", self.s("/alert/accept"), {})

    def screenshot(self, path):
        with open(path, "wb") as f:
            f.write(base64.b64decode(self.call("GET", self.s("/screenshot"))))

    def quit(self):
        if self.session:
            try:
                self.call("DELETE", self.s(""))
            except Exception:
                pass


class Farm:
    """A master with the dashboard on a port the system chooses, and a worker."""

    def __init__(self, binary, scratch):
        self.bin = binary
        self.dir = scratch
        self.procs = []

    def run(self, *args):
        return subprocess.run([self.bin, *args], check=True, capture_output=True, text=True)

    def spawn(self, name, *args):
        log = open(os.path.join(self.dir, name + ".log"), "w")
        p = subprocess.Popen([self.bin, *args], stdout=log, stderr=subprocess.STDOUT,
                             start_new_session=True)
        self.procs.append(p)
        return p

    def start(self):
        keys = os.path.join(self.dir, "keys")
        self.run("keygen", "admin", "--dir", keys)
        self.token = open(os.path.join(keys, "admin.token")).read().split("\n")[-2].strip()
        self.workers = "ipc://%s/w" % self.dir
        self.clients = "ipc://%s/c" % self.dir
        spool = os.path.join(self.dir, "spool")
        self.spawn("master", "master", "--workers", self.workers, "--clients", self.clients,
                   "--spool", spool, "--http", "127.0.0.1:0", "--http-token-file",
                   os.path.join(keys, "admin.token"), "--no-journal")

        def endpoint():
            with open(os.path.join(spool, "endpoints")) as f:
                for line in f:
                    if line.startswith("http "):
                        return line.split()[1]
        self.url = wait_for("the master's dashboard endpoint", endpoint)

    def submit(self, scene, *args):
        return int(self.run("submit", scene, "--master", self.clients, *args).stdout.strip())

    def stop(self):
        """Stops every process with SIGTERM; returns their exit statuses (0: a clean stop, and
        in the sanitizer build no leak or error report)."""
        for p in self.procs:
            if p.poll() is None:
                os.killpg(p.pid, signal.SIGTERM)
        for p in self.procs:
            try:
                p.wait(timeout=60)
            except subprocess.TimeoutExpired:
                os.killpg(p.pid, signal.SIGKILL)
                p.wait()
        return [p.returncode for p in self.procs]


# The preview as the page shows it, drawn into a canvas: its pixels, not its URL.
PREVIEW_PIXELS = """
const img = document.getElementById('preview');
if (!img || !img.complete || !img.naturalWidth) return null;
const c = document.createElement('canvas');
c.width = img.naturalWidth; c.height = img.naturalHeight;
c.getContext('2d').drawImage(img, 0, 0);
return [img.dataset.version, c.toDataURL('image/png')];
"""


def main():
    binary = os.environ.get("PRISMFARM_BIN")
    source = os.environ.get("PRISMFARM_SOURCE_DIR",
                            os.path.dirname(os.path.dirname(os.path.dirname(__file__))))
    build = os.environ.get("PRISMFARM_BUILD_DIR", os.getcwd())
    if not binary or not os.access(binary, os.X_OK):
        fail("PRISMFARM_BIN does not name the prismfarm binary")
    for tool, pkg in ((CHROMIUM, "chromium"), (CHROMEDRIVER, "chromium-driver")):
        if not os.access(tool, os.X_OK):
            skip("%s is missing: install the Debian package %s (a test package: "
                 "deploy/install-deps.sh --test)" % (tool, pkg))
    scratch = tempfile.mkdtemp(prefix="prismfarm-browser-")
    farm = Farm(binary, scratch)
    driver_port = free_port()
    driver_log = open(os.path.join(scratch, "chromedriver.log"), "w")
    driver = subprocess.Popen([CHROMEDRIVER, "--port=%d" % driver_port],
                              stdout=driver_log, stderr=subprocess.STDOUT,
                              start_new_session=True)
    wd = WebDriver(driver_port)
    ok = False
    try:
        try:
            wait_for("chromedriver to answer", lambda: wd.call("GET", "/status")["ready"], 60)
            wd.start()
        except Exception as e:
            skip("Chromium cannot start headless here: %s" % e)

        farm.start()
        scene = os.path.join(source, "scenes", "cornell.pbrt")
        # A small job that ends, and one too long to end by itself (65536 spp in 17 passes):
        # its passes grow, so a preview follows pass after pass until it is cancelled.
        short = farm.submit(scene, "--res", "32x32", "--spp", "16", "--name", "cornell-small")
        long = farm.submit(scene, "--res", "128x96", "--spp", "65536", "--name", "cornell-long")
        farm.spawn("worker", "worker", "--connect", farm.workers, "--threads", "1", "--quiet")

        # Without a token: the count of jobs and how to sign in, no job's name.
        admin = {"Authorization": "Bearer " + farm.token}
        wd.get(farm.url + "#/jobs")
        wait_for("the count of jobs without a token", lambda: wd.js(
            "const c = document.getElementById('job-counts');"
            "return c && /\\d+ (queued|running)/.test(c.textContent)"
            " && !!document.getElementById('sign-in')"))
        if "cornell" in wd.text("#view"):
            fail("the page shows a job's name without a token: %s" % wd.text("#view"))

        # Signed in as the administrator: the job list.
        wd.type("#token", farm.token)
        wd.click("#token-save")
        wait_for("the page to take the token", lambda: "admin" in wd.text("#whoami"))
        wait_for("job %d in the list" % long,
                 lambda: wd.js("return !!document.querySelector('tr[data-job=\"%d\"]')" % long))
        wait_for("job %d done in the list" % short, lambda: wd.js(
            "const r = document.querySelector('tr[data-job=\"%d\"] .state');"
            "return r && r.textContent === 'done'" % short))
        names = wd.js("return [...document.querySelectorAll('#jobs-table tbody tr td:nth-child(2)')]"
                      ".map(e => e.textContent)")
        if "cornell-small" not in names or "cornell-long" not in names:
            fail("the job list shows %s" % names)

        # The job page: the preview changes between two passes.
        wd.get(farm.url + "#/job/%d" % long)
        first = wait_for("a first preview of job %d" % long, lambda: wd.js(PREVIEW_PIXELS))
        second = wait_for("a second, different preview of job %d" % long, lambda: (
            lambda got: got if got and got[0] != first[0] else None)(wd.js(PREVIEW_PIXELS)))
        if first[1] == second[1]:
            fail("the preview of version %s has the pixels of version %s" % (second[0], first[0]))
        wait_for("the error curve", lambda: wd.js(
            "return document.querySelectorAll('#error-plot circle').length >= 2"))
        wait_for("a running task with its worker", lambda: wd.js(
            "return document.querySelectorAll('#tasks-body tr').length >= 1"))
        wait_for("the job's log", lambda: "started" in wd.text("#job-log"))
        shot = os.path.join(build, "dashboard.png")
        wd.screenshot(shot)
        if os.environ.get("PRISMFARM_UPDATE_SCREENSHOT") == "1":
            shutil.copyfile(shot, os.path.join(source, "docs", "dashboard.png"))

        # Forgetting the token: the job page asks to sign in, and shows neither the preview
        # nor the log; its preview, log and a cancel without a token are refused.
        wd.click("#token-clear")
        wait_for("the job page asking to sign in", lambda: wd.js(
            "return !!document.getElementById('sign-in') && !document.getElementById('preview')"
            " && !document.getElementById('job-log')"))
        for what in ("preview.png", "log", "tasks"):
            status, _ = http_json(farm.url + "api/jobs/%d/%s" % (long, what))
            if status != 401:
                fail("GET %s of job %d without a token got %d, expected 401" % (what, long, status))
        status, body = http_json(farm.url + "api/jobs/%d/cancel" % long, "POST", b"")
        if status != 401:
            fail("a POST without a token got %d %s, expected 401" % (status, body))
        status, job = http_json(farm.url + "api/jobs/%d" % long, headers=admin)
        if status != 200 or job["state"] != "running":
            fail("after a refused cancel job %d is %s" % (long, job.get("state")))

        # With the administrator's token again the page cancels the job, and the worker stops.
        wd.type("#token", farm.token)
        wd.click("#token-save")
        wait_for("the page to take the token", lambda: "admin" in wd.text("#whoami"))
        wait_for("the cancel button offered", lambda: wd.js(
            "const b = document.getElementById('action-cancel'); return b && !b.hidden"))
        wd.click("#action-cancel")
        wd.accept_alert()
        wait_for("job %d cancelled on its page" % long,
                 lambda: wd.text("#job-state") == "cancelled")
        wait_for("no task of job %d running" % long, lambda: http_json(
            farm.url + "api/jobs/%d/tasks" % long, headers=admin)[1]["tasks"] == [])
        if wd.js("const b = document.getElementById('action-cancel'); return !b.hidden"):
            fail("a cancelled job's page still offers Cancel")
        wd.get(farm.url + "#/workers")
        wait_for("the worker idle on the workers page", lambda: wd.js(
            "const r = document.querySelector('#workers-table tbody tr');"
            "return r && r.querySelector('.state').textContent === 'idle'"
            " && r.children[5].textContent === '0'"))

        # A frame sequence (docs/farm.md): one row in the list, its frames on its page, and a
        # frame's page linking back to it.
        frames = os.path.join(scratch, "frames")
        os.mkdir(frames)
        for k in (1, 2):
            with open(os.path.join(frames, "walk%d.pbrt" % k), "w") as f:
                f.write('LookAt %d 1 -3  0 0.5 0  0 1 0\nCamera "perspective"\n'
                        'Film "spectral" "integer xresolution" [ 16 ] "integer yresolution" [ 8 ]\n'
                        'Sampler "independent" "integer pixelsamples" [ 4 ]\nWorldBegin\n'
                        'LightSource "infinite" "rgb L" [ 0.5 0.5 0.5 ]\n'
                        'Shape "sphere" "float radius" [ 0.5 ]\n' % (k - 1))
        seq = int(farm.run("submit", os.path.join(frames, "walk1.pbrt"),
                           os.path.join(frames, "walk2.pbrt"), "--master",
                           farm.clients).stdout.strip())
        wd.get(farm.url + "#/jobs")
        wait_for("sequence %d done in the list with its 2 frames" % seq, lambda: wd.js(
            "const r = document.querySelector('tr[data-job=\"%d\"]');"
            "return r && r.querySelector('.state').textContent === 'done'"
            " && r.textContent.includes('(2 frames)')" % seq))
        if wd.js("return !!document.querySelector('tr[data-job=\"%d\"]')" % (seq + 1)):
            fail("frame job %d is listed on its own beside its sequence %d" % (seq + 1, seq))
        wd.get(farm.url + "#/job/%d" % seq)
        wait_for("the 2 frames of sequence %d on its page" % seq, lambda: wd.js(
            "return [...document.querySelectorAll('#frames-body tr .state')]"
            ".map(e => e.textContent).join() === 'done,done'"))
        wd.click('#frames-body tr[data-job="%d"]' % (seq + 2))
        wait_for("frame 2's page naming its sequence", lambda: "2 of job %d" % seq in wd.text("#job-facts"))
        codes = farm.stop()
        if any(codes):
            fail("the farm's processes ended with statuses %s, expected 0 (see master.log, "
                 "worker.log)" % codes)
        ok = True
        print("test_dashboard: passed (preview versions %s -> %s; screenshot %s)" %
              (first[0], second[0], shot))
    finally:
        wd.quit()
        if driver.poll() is None:
            os.killpg(driver.pid, signal.SIGTERM)
            driver.wait()
        farm.stop()
        if ok:
            shutil.rmtree(scratch, ignore_errors=True)
        else:
            print("test_dashboard: logs kept in %s" % scratch)
            for name in ("master.log", "worker.log", "chromedriver.log"):
                path = os.path.join(scratch, name)
                if os.path.exists(path):
                    print("---- %s (last lines)" % name)
                    print("".join(open(path).readlines()[-25:]))


if __name__ == "__main__":
    try:
        main()
    except AssertionError as e:
        print("test_dashboard: FAILED: %s" % e, flush=True)
        sys.exit(1)
