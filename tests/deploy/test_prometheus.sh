#!/usr/bin/env bash
# Debian's real Prometheus server scrapes a running master's dashboard (issue 26, finding 5;
# docs/deploy.md, "Prometheus"): a master on ipc:// endpoints in a scratch folder with --http on
# a port the system chooses and --metrics-token-file (the scrapers' token), one job queued on
# it; Prometheus started here with the scrape configuration docs/deploy.md shows (bearer token
# from a file, 1 s interval), on its own port and storage in the scratch folder (the system's
# /etc/prometheus is neither read nor changed). It passes when /metrics answers 401 without a
# token and 200 with the scrapers' token in Prometheus' text format, and Prometheus' HTTP query
# API returns the prismfarm_ series it scraped: up 1 for the target, prismfarm_jobs with the
# queued job, prismfarm_queue_depth.
#
# Exit 0: passed; 1: failed (with what, and the logs); 77: skipped, only when `prometheus` is
# not installed (Debian 12: apt-get install prometheus, as deploy/install-deps.sh --test does).
# PRISMFARM_REQUIRE_PROMETHEUS=1 makes a skip a failure. Every wait has a generous deadline and
# nothing is timed.
set -uo pipefail

me=test_prometheus
skip() {
  if [ "${PRISMFARM_REQUIRE_PROMETHEUS:-0}" = 1 ]; then
    echo "$me: FAILED: cannot run, and PRISMFARM_REQUIRE_PROMETHEUS=1: $*" >&2
    exit 1
  fi
  echo "$me: SKIPPED: $*"
  exit 77
}

src=${PRISMFARM_SOURCE_DIR:-$(cd "$(dirname "$0")/../.." && pwd)}
bin=${PRISMFARM_BIN:-$src/build/cli/prismfarm}
[ -x "$bin" ] || { echo "$me: FAILED: no prismfarm executable at '$bin' (set PRISMFARM_BIN)" >&2; exit 1; }
command -v prometheus >/dev/null 2>&1 ||
  skip "'prometheus' is not installed (Debian 12: apt-get install prometheus, as" \
    "deploy/install-deps.sh --test does)"
command -v python3 >/dev/null 2>&1 || skip "python3 is not installed"

scratch=$(mktemp -d "${TMPDIR:-/tmp}/pf-prom-XXXXXX") || { echo "$me: FAILED: mktemp" >&2; exit 1; }
pids=()
cleanup() {
  local p
  for p in "${pids[@]}"; do kill "$p" 2>/dev/null; done
  for p in "${pids[@]}"; do wait "$p" 2>/dev/null; done
  [ "${PRISMFARM_KEEP_SCRATCH:-0}" = 1 ] || rm -rf "$scratch"
}
trap cleanup EXIT
fail() {
  echo "$me: FAILED: $*" >&2
  local f
  for f in "$scratch"/master.log "$scratch"/prometheus.log; do
    [ -f "$f" ] && { echo "---- $f (last lines)" >&2; tail -n 25 "$f" >&2; }
  done
  exit 1
}

# Waits up to 120 s for a command to succeed.
wait_for() {
  local what=$1 t
  shift
  for ((t = 0; t < 1200; t++)); do
    "$@" && return 0
    sleep 0.1
  done
  fail "no $what within 120 s"
}

"$bin" keygen prom --dir "$scratch/keys" >/dev/null || fail "keygen"
# Prometheus sends a credentials_file's whole content: a copy with the token line alone.
grep -v '^#' "$scratch/keys/prom.token" | grep -v '^$' >"$scratch/prometheus.token"
token=$(cat "$scratch/prometheus.token")
spool=$scratch/spool
"$bin" master --workers "ipc://$scratch/w" --clients "ipc://$scratch/c" --spool "$spool" \
  --no-journal --http 127.0.0.1:0 --metrics-token-file "$scratch/keys/prom.token" \
  >"$scratch/master.log" 2>&1 &
pids+=($!)
http_url() { grep -s '^http ' "$spool/endpoints" | awk '{print $2}'; }
has_url() { [ -n "$(http_url)" ]; }
wait_for "dashboard endpoint in $spool/endpoints" has_url
url=$(http_url)
# One job and no worker: it stays queued.
"$bin" submit "$src/tests/data/render/tiny.pbrt" --master "ipc://$scratch/c" --spp 4 --quiet \
  >/dev/null || fail "submit"

# /metrics by hand: 401 without a token, 200 in the text format with the scrapers' token.
python3 - "$url" "$token" <<'EOF' || fail "/metrics by hand"
import sys, urllib.request, urllib.error
url, token = sys.argv[1], sys.argv[2]
try:
    urllib.request.urlopen(url + "metrics", timeout=30)
    sys.exit("/metrics answered without a token")
except urllib.error.HTTPError as e:
    if e.code != 401:
        sys.exit("/metrics without a token: %d, expected 401" % e.code)
r = urllib.request.urlopen(urllib.request.Request(url + "metrics",
                           headers={"Authorization": "Bearer " + token}), timeout=30)
ctype, text = r.headers["Content-Type"], r.read().decode()
if not ctype.startswith("text/plain; version=0.0.4"):
    sys.exit("Content-Type %s" % ctype)
for line in ("# TYPE prismfarm_jobs gauge", 'prismfarm_jobs{state="queued"} 1',
             "# TYPE prismfarm_journal_writes_total counter"):
    if line not in text.splitlines():
        sys.exit("no line '%s' in:\n%s" % (line, text))
EOF

# Prometheus, configured as docs/deploy.md shows (the target and interval of this test).
prom_port=$(python3 -c 'import socket; s=socket.socket(); s.bind(("127.0.0.1",0)); print(s.getsockname()[1])')
target=${url#http://}
target=${target%/}
cat >"$scratch/prometheus.yml" <<EOF
global:
  scrape_interval: 1s
scrape_configs:
  - job_name: prismfarm
    metrics_path: /metrics
    authorization:
      type: Bearer
      credentials_file: $scratch/prometheus.token
    static_configs:
      - targets: ['$target']
EOF
prometheus --config.file="$scratch/prometheus.yml" --storage.tsdb.path="$scratch/tsdb" \
  --web.listen-address="127.0.0.1:$prom_port" >"$scratch/prometheus.log" 2>&1 &
pids+=($!)

# Its query API: the target up, and the prismfarm_ series it scraped.
query() {
  python3 - "$prom_port" "$1" "$2" <<'EOF'
import json, sys, urllib.parse, urllib.request
port, q, want = sys.argv[1], sys.argv[2], float(sys.argv[3])
try:
    r = urllib.request.urlopen("http://127.0.0.1:%s/api/v1/query?query=%s" %
                               (port, urllib.parse.quote(q)), timeout=10)
    res = json.load(r)["data"]["result"]
except Exception:
    sys.exit(1)
sys.exit(0 if res and float(res[0]["value"][1]) == want else 1)
EOF
}
wait_for "'up{job=\"prismfarm\"} == 1' from Prometheus" query 'up{job="prismfarm"}' 1
wait_for "prismfarm_jobs{state=\"queued\"} from Prometheus" query 'prismfarm_jobs{state="queued"}' 1
wait_for "prismfarm_queue_depth from Prometheus" query 'count(prismfarm_queue_depth)' 1
n=$(python3 - "$prom_port" <<'EOF'
import json, sys, urllib.request
r = urllib.request.urlopen("http://127.0.0.1:%s/api/v1/label/__name__/values" % sys.argv[1],
                           timeout=10)
print(len([n for n in json.load(r)["data"] if n.startswith("prismfarm_")]))
EOF
)
echo "$me: passed (Prometheus $(prometheus --version 2>&1 | head -1 | awk '{print $3}') scraped $n prismfarm_ series from $url)"
