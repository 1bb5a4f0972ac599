#!/usr/bin/env bash
# System packages grainflow uses beyond PyPI, on Debian/Ubuntu (run as root, or with sudo):
# - libvulkan1 + mesa-vulkan-drivers: OVITO's renderer starts Vulkan even for its software
#   ray tracer; Mesa's CPU driver (lavapipe) lets `grainflow view` render 3D runs on a
#   machine without a GPU. Without them 3D movies need `--renderer matplotlib`.
# - lammps (optional, --with-lammps): the peer of the benchmarks in benchmarks/.
# Packages already present are left alone; the script never fails the caller's build when
# apt is unavailable (it says so and exits 0: the tests that need OVITO then skip).
set -uo pipefail
packages=()
ldconfig -p | grep -q 'libvulkan.so.1' || packages+=(libvulkan1)
ls /usr/share/vulkan/icd.d/lvp_icd*.json >/dev/null 2>&1 || packages+=(mesa-vulkan-drivers)
if [[ "${1:-}" == "--with-lammps" ]] && ! command -v lmp >/dev/null; then
    packages+=(lammps)
fi
if (( ${#packages[@]} == 0 )); then
    exit 0
fi
sudo=""
if (( EUID != 0 )); then
    command -v sudo >/dev/null && sudo="sudo" || {
        echo "setup_system: not root and no sudo; install ${packages[*]} by hand" >&2; exit 0; }
fi
if ! { $sudo apt-get update -qq && \
       DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends \
           "${packages[@]}"; } >/dev/null; then
    echo "setup_system: could not install ${packages[*]} with apt-get" >&2
fi
exit 0
