#!/usr/bin/env bash
# Installs rumid as a systemd service on a Debian 12 ground station: the
# executables, the unit template rumid@.service, a default config and the
# system user. Idempotent; an existing /etc/rumi/*.yaml is never overwritten.
#   scripts/install-service.sh [--prefix DIR]        build if needed, install
#   scripts/install-service.sh --uninstall [--purge] remove (--purge: also /etc/rumi and /var/lib/rumi)
# Then: systemctl enable --now rumid@default   (config /etc/rumi/default.yaml)
#       rumi status --instance default
set -euo pipefail
cd "$(dirname "$0")/.."

PREFIX=/usr/local
UNINSTALL=0
PURGE=0
while [ $# -gt 0 ]; do
  case "$1" in
    --prefix) PREFIX=$2; shift 2 ;;
    --uninstall) UNINSTALL=1; shift ;;
    --purge) PURGE=1; shift ;;
    -h|--help) sed -n '2,9p' "$0"; exit 0 ;;
    *) echo "install-service.sh: unknown argument '$1' (see --help)" >&2; exit 2 ;;
  esac
done
[ "$(id -u)" -eq 0 ] || { echo "install-service.sh: run as root (it creates a user and writes /etc)" >&2; exit 1; }

BINARIES=(rumid rumi rumi-front rumi-back rumi-manager rumi-ipc-status)
UNIT_DIR=/etc/systemd/system
UNIT=$UNIT_DIR/rumid@.service
systemd_running() { [ -d /run/systemd/system ] && command -v systemctl >/dev/null; }

if [ "$UNINSTALL" -eq 1 ]; then
  if systemd_running; then
    for u in $(systemctl list-units --all --plain --no-legend 'rumid@*' | awk '{print $1}'); do
      systemctl disable --now "$u" || true
    done
  fi
  rm -f "$UNIT"
  for b in "${BINARIES[@]}"; do rm -f "$PREFIX/bin/$b"; done
  rm -rf "$PREFIX/share/rumi/view"
  rm -rf "$PREFIX/share/doc/rumi"
  if [ "$PURGE" -eq 1 ]; then
    rm -rf /etc/rumi /var/lib/rumi
    if id rumi >/dev/null 2>&1; then userdel rumi; fi
    echo "install-service.sh: removed rumid, its config, its state and the rumi user"
  else
    echo "install-service.sh: removed rumid (kept /etc/rumi, /var/lib/rumi and the rumi user; --purge removes them)"
  fi
  systemd_running && systemctl daemon-reload || true
  exit 0
fi

# Build what is installed (packages too, through setup.sh) unless it is there.
missing=0
for b in "${BINARIES[@]}"; do [ -x "build/bin/$b" ] || missing=1; done
if [ "$missing" -eq 1 ]; then scripts/setup.sh "${BINARIES[@]}"; fi

install -d "$PREFIX/bin"
for b in "${BINARIES[@]}"; do install -m 0755 "build/bin/$b" "$PREFIX/bin/$b"; done
# The web view's page (docs/view.md): rumid finds it beside its bin/.
install -d "$PREFIX/share/rumi/view"
install -m 0644 apps/view/web/index.html apps/view/web/view.js apps/view/web/view.css "$PREFIX/share/rumi/view/"
install -d "$PREFIX/share/doc/rumi"
install -m 0644 docs/daemon.md "$PREFIX/share/doc/rumi/daemon.md"

if ! id rumi >/dev/null 2>&1; then
  useradd --system --user-group --home-dir /var/lib/rumi --no-create-home --shell /usr/sbin/nologin \
    --comment "rumi SLAM daemon" rumi
  echo "install-service.sh: created the system user rumi"
fi
getent group video >/dev/null && usermod -a -G video rumi

sed "s|/usr/local/bin/rumid|$PREFIX/bin/rumid|" configs/systemd/rumid@.service > "$UNIT.tmp"
mv "$UNIT.tmp" "$UNIT"
chmod 0644 "$UNIT"

install -d -m 0755 /etc/rumi
if [ -e /etc/rumi/default.yaml ]; then
  echo "install-service.sh: kept the existing /etc/rumi/default.yaml"
else
  install -m 0644 configs/daemon.yaml /etc/rumi/default.yaml
fi
install -d -m 0750 -o rumi -g rumi /var/lib/rumi

# The unit and the config as systemd and rumid will read them.
systemd-analyze verify "$UNIT_DIR/rumid@default.service"
"$PREFIX/bin/rumi" config check /etc/rumi/default.yaml
if systemd_running; then
  systemctl daemon-reload
  echo "install-service.sh: installed. Start it: systemctl enable --now rumid@default; watch it: rumi status"
else
  echo "install-service.sh: installed (systemd is not running here: start rumid@default where it is)"
fi
