#!/usr/bin/env bash
# Builds prismfarm (deploy/build.sh release) and installs the binary, the systemd units, example
# settings and the deployment guide. Idempotent: a re-run reports each file as unchanged or
# updated, never overwrites /etc/prismfarm/*.env, and creates the `prismfarm` user only once.
set -euo pipefail

usage() {
  cat <<'EOF'
usage: deploy/install.sh [options]

Builds prismfarm and installs, under PREFIX (default /usr/local):
  PREFIX/bin/prismfarm
  PREFIX/share/doc/prismfarm/deploy.md, security.md
  /etc/systemd/system/prismfarm-master.service, prismfarm-worker@.service
  /etc/prismfarm/master.env, worker.env        (examples, only if absent)
  /etc/prismfarm/keys/host.key, host.pub       (this host's CURVE key pair, only if absent)
  /etc/prismfarm/authorized/                   (the master's authorised public keys)
and creates the system user `prismfarm` that the units run as. Then exchange the public keys
(docs/security.md) and enable what the host is for:
  systemctl enable --now prismfarm-master                  # the master host
  systemctl enable --now prismfarm-worker@MASTERHOST       # each render host
Run deploy/install-deps.sh first (build dependencies, and the run-time libraries with them).

options:
  --prefix DIR     installation prefix (default /usr/local)
  --destdir DIR    stage every file under DIR (for packaging or a test); creates no user and
                   does not reload systemd; needs no root
  --binary FILE    install this already built prismfarm instead of building one
  --no-user        do not create the `prismfarm` user
  -h, --help       this text
EOF
}

prefix=/usr/local
destdir=
binary=
make_user=1
while [ $# -gt 0 ]; do
  case "$1" in
    --prefix) [ $# -ge 2 ] || { echo "install.sh: --prefix needs a directory" >&2; exit 2; }; prefix=$2; shift 2 ;;
    --destdir) [ $# -ge 2 ] || { echo "install.sh: --destdir needs a directory" >&2; exit 2; }; destdir=$2; shift 2 ;;
    --binary) [ $# -ge 2 ] || { echo "install.sh: --binary needs a file" >&2; exit 2; }; binary=$2; shift 2 ;;
    --no-user) make_user=0; shift ;;
    -h|--help) usage; exit 0 ;;
    *) echo "install.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
case "$prefix" in
  /*) prefix=${prefix%/} ;;
  *) echo "install.sh: --prefix must be an absolute path, got '$prefix'" >&2; exit 2 ;;
esac
# The prefix is pasted into unit files: keep it to characters that need no quoting there.
if [[ ! "$prefix" =~ ^[A-Za-z0-9/._+-]+$ ]]; then
  echo "install.sh: --prefix '$prefix' has characters a unit file would need quoted" >&2
  exit 2
fi
if [ -z "$destdir" ] && [ "$(id -u)" -ne 0 ]; then
  echo "install.sh: run as root (or with --destdir DIR to stage the files)" >&2
  exit 1
fi

repo=$(cd "$(dirname "$0")/.." && pwd)
if [ -z "$binary" ]; then
  echo "install.sh: building (deploy/build.sh release)"
  bash "$repo/deploy/build.sh" release
  binary=$repo/build/cli/prismfarm
fi
if [ ! -x "$binary" ]; then
  echo "install.sh: '$binary' is not an executable" >&2
  exit 1
fi

work=$(mktemp -d)
trap 'rm -rf "$work"' EXIT

changed_units=0
# Installs SRC as DST (under destdir) with MODE unless DST already has the same bytes.
put() {
  local src=$1 dst=$destdir$2 mode=$3
  if [ -f "$dst" ] && cmp -s "$src" "$dst"; then
    echo "unchanged  $dst"
    return
  fi
  local verb=installed
  [ -e "$dst" ] && verb=updated
  install -D -m "$mode" "$src" "$dst"
  echo "$verb  $dst"
  case "$dst" in *.service) changed_units=1 ;; esac
}

# Installs an example settings file only when the administrator has none.
put_example() {
  local src=$1 dst=$destdir$2
  if [ -e "$dst" ]; then
    echo "kept       $dst (exists; the example is $src)"
    return
  fi
  install -D -m 0644 "$src" "$dst"
  echo "installed  $dst"
}

put "$binary" "$prefix/bin/prismfarm" 0755
put "$repo/docs/deploy.md" "$prefix/share/doc/prismfarm/deploy.md" 0644
put "$repo/docs/security.md" "$prefix/share/doc/prismfarm/security.md" 0644
for unit in prismfarm-master.service prismfarm-worker@.service; do
  sed -e "s|/usr/local/bin/prismfarm|$prefix/bin/prismfarm|g" \
      -e "s|/usr/local/share/doc/prismfarm|$prefix/share/doc/prismfarm|g" \
      "$repo/deploy/systemd/$unit" >"$work/$unit"
  put "$work/$unit" "/etc/systemd/system/$unit" 0644
done
put_example "$repo/deploy/systemd/master.env" /etc/prismfarm/master.env
put_example "$repo/deploy/systemd/worker.env" /etc/prismfarm/worker.env

# This host's key pair (docs/security.md), made once and never replaced (a new pair would lock
# the host out until its new host.pub is authorised), owned by the user the units run as; and
# the folder of public keys a master lets in.
make_keys() {
  local keys=$destdir/etc/prismfarm/keys auth=$destdir/etc/prismfarm/authorized
  if [ -d "$auth" ]; then
    echo "kept       $auth"
  else
    install -d -m 0755 "$auth"
    echo "installed  $auth"
  fi
  if [ -e "$keys/host.key" ]; then
    echo "kept       $keys/host.key"
  else
    "$binary" keygen host --dir "$keys" >/dev/null
    echo "installed  $keys/host.key (secret, 0600) and host.pub"
  fi
  if [ -z "$destdir" ]; then
    if getent passwd prismfarm >/dev/null; then
      chown prismfarm:prismfarm "$keys" "$keys/host.key" "$keys/host.pub"
      chmod 0700 "$keys"
    else
      echo "note: no user prismfarm: $keys stays root's (the units cannot read it)"
    fi
  fi
}

if [ -n "$destdir" ]; then
  make_keys
  echo "staged under $destdir: no user created, systemd not reloaded"
  exit 0
fi

if [ "$make_user" -eq 1 ]; then
  if getent passwd prismfarm >/dev/null; then
    echo "unchanged  user prismfarm"
  else
    useradd --system --user-group --home-dir /var/lib/prismfarm --no-create-home \
            --shell /usr/sbin/nologin --comment "prismfarm render farm" prismfarm
    echo "created    user prismfarm"
  fi
fi
make_keys

if [ "$changed_units" -eq 1 ]; then
  if [ -d /run/systemd/system ]; then
    systemctl daemon-reload
    echo "reloaded   systemd"
  else
    echo "note: systemd is not running here; the units take effect where it is"
  fi
fi
