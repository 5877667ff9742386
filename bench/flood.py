#!/usr/bin/env python3
"""Floods of idle connections against a master (issue 26, finding 4; docs/security.md,
"Connections"): how long a real user waits for an answer while they are held.

  dashboard: N idle TCP connections to the dashboard's port (--http), all from 127.0.0.1 as
             everyone behind an SSH tunnel is; then GET / is timed.
  clients:   N idle TCP connections to the clients endpoint from 127.0.0.1 (which never send
             a byte, so they never finish a CURVE handshake); then `prismfarm jobs` with an
             authorised key from the same address is timed.

usage: bench/flood.py [--bin build/cli/prismfarm] [--dash 64,300] [--clients 2000] [--runs 3]

Prints one line per measurement: the flood, the run and the seconds to the answer (or the
failure). Times depend on the machine's load; compare a build before and after on one machine.
"""
import argparse
import os
import resource
import socket
import subprocess
import sys
import tempfile
import time
import urllib.request


def endpoints(spool):
    out = {}
    deadline = time.time() + 60
    while time.time() < deadline:
        try:
            for line in open(os.path.join(spool, "endpoints")):
                k, v = line.split()[:2]
                out[k] = v
            if "clients" in out and "http" in out:
                return out
        except OSError:
            pass
        time.sleep(0.1)
    sys.exit("no endpoints file in %s" % spool)


def hold(host, port, n):
    conns = []
    for _ in range(n):
        s = socket.socket()
        s.connect((host, port))
        conns.append(s)
    return conns


def timed(f):
    t = time.monotonic()
    try:
        ok = f()
    except Exception as e:  # noqa: BLE001 -- reported, not raised
        ok = "failed: %s" % e
    return time.monotonic() - t, ok


def main():
    ap = argparse.ArgumentParser()
    ap.add_argument("--bin", default="build/cli/prismfarm")
    ap.add_argument("--dash", default="64,300,2000")
    ap.add_argument("--clients", default="2000")
    ap.add_argument("--runs", type=int, default=3)
    a = ap.parse_args()
    soft, hard = resource.getrlimit(resource.RLIMIT_NOFILE)
    resource.setrlimit(resource.RLIMIT_NOFILE, (hard, hard))
    d = tempfile.mkdtemp(prefix="pf-flood-")
    keys = os.path.join(d, "keys")
    auth = os.path.join(d, "auth")
    os.makedirs(auth)
    for name in ("master", "alice"):
        subprocess.run([a.bin, "keygen", name, "--dir", keys], check=True, capture_output=True)
    os.link(os.path.join(keys, "alice.pub"), os.path.join(auth, "alice.pub"))
    spool = os.path.join(d, "spool")
    log = open(os.path.join(d, "master.log"), "w")
    master = subprocess.Popen([a.bin, "master", "--workers", "tcp://127.0.0.1:*", "--clients",
                               "tcp://127.0.0.1:*", "--spool", spool, "--no-journal", "--key",
                               os.path.join(keys, "master.key"), "--authorized", auth,
                               "--http", "127.0.0.1:0", "--quiet"], stdout=log, stderr=log)
    try:
        ep = endpoints(spool)
        url = ep["http"]
        dport = int(url.rsplit(":", 1)[1].strip("/"))
        cport = int(ep["clients"].rsplit(":", 1)[1])
        print("prismfarm %s; master log %s" % (a.bin, log.name))

        def get():
            with urllib.request.urlopen(url, timeout=60) as r:
                return r.status == 200

        def jobs():
            r = subprocess.run([a.bin, "jobs", "--master", ep["clients"], "--key",
                                os.path.join(keys, "alice.key"), "--master-key",
                                os.path.join(keys, "master.pub")],
                               capture_output=True, text=True, timeout=120)
            return r.returncode == 0 or r.stderr.strip()

        for n in [int(x) for x in a.dash.split(",") if x]:
            for run in range(a.runs):
                conns = hold("127.0.0.1", dport, n)
                time.sleep(0.5)
                t, ok = timed(get)
                print("dashboard GET / under %4d idle connections, run %d: %.3f s %s" %
                      (n, run + 1, t, "" if ok is True else ok), flush=True)
                for s in conns:
                    s.close()
                time.sleep(1)
        for n in [int(x) for x in a.clients.split(",") if x]:
            for run in range(a.runs):
                conns = hold("127.0.0.1", cport, n)
                time.sleep(0.5)
                t, ok = timed(jobs)
                print("prismfarm jobs under %4d idle connections, run %d: %.3f s %s" %
                      (n, run + 1, t, "" if ok is True else ok), flush=True)
                for s in conns:
                    s.close()
                time.sleep(1)
    finally:
        master.terminate()
        master.wait()


if __name__ == "__main__":
    main()
