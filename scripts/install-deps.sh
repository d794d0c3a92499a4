#!/usr/bin/env bash
# Installs the system tools the project needs, only when missing (idempotent).
# Usage: scripts/install-deps.sh [verilator] [opencv] [yosys] [venv]   (no argument = all)
set -euo pipefail
want=("$@"); [ ${#want[@]} -eq 0 ] && want=(verilator opencv yosys venv)
pkgs=()
for tool in "${want[@]}"; do
  case "$tool" in
    verilator) command -v verilator >/dev/null || pkgs+=(verilator) ;;
    opencv)    pkg-config --exists opencv4 2>/dev/null || pkgs+=(libopencv-dev) ;;
    yosys)     command -v yosys >/dev/null || pkgs+=(yosys) ;;
    venv)      python3 -c 'import ensurepip, venv' 2>/dev/null || pkgs+=(python3-venv) ;; # Debian splits it out
    *) echo "install-deps: unknown tool '$tool' (known: verilator opencv yosys venv)" >&2; exit 2 ;;
  esac
done
[ ${#pkgs[@]} -eq 0 ] && exit 0
SUDO=""; [ "$(id -u)" -ne 0 ] && SUDO="sudo"
echo "install-deps: installing ${pkgs[*]} with apt-get" >&2
export DEBIAN_FRONTEND=noninteractive
$SUDO apt-get update -qq
$SUDO apt-get install -y -qq --no-install-recommends "${pkgs[@]}" >/dev/null
