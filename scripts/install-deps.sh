#!/usr/bin/env bash
# Installs what bondem needs to build, test and plot, from Debian's packages only.
# Idempotent: packages already installed are skipped, and nothing is fetched when all are present.
set -euo pipefail

packages=(
  g++ cmake make ninja-build          # toolchain (the presets build with Ninja)
  clang-format                        # the formatting check of the test script
  libeigen3-dev                       # small-vector maths
  libvtk9-dev                         # VTK XML output for ParaView
  libyaml-cpp-dev libcli11-dev        # case files, command line
  libgtest-dev libbenchmark-dev       # tests, microbenchmarks
  libhwy-dev                          # Google Highway: the SIMD pair pass, dispatched at run time
  libopenmpi-dev openmpi-bin          # MPI: distributed runs (issue 18) and their tests
  gnuplot-nox                         # figures of the main job
  # scripts/render-png.py: VTK's Python, and Xvfb as its off-screen X server (Debian's VTK 9.1
  # draws through X11 only: no EGL or OSMesa) with Mesa's llvmpipe; DejaVu for the colour bar
  python3-vtk9 xvfb xauth libgl1-mesa-dri fonts-dejavu-core
)

missing=()
for package in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$package" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$package")
  fi
done

if ((${#missing[@]} == 0)); then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

sudo=""
if [ "$(id -u)" -ne 0 ]; then sudo="sudo"; fi
echo "install-deps: installing ${missing[*]}"
export DEBIAN_FRONTEND=noninteractive
$sudo apt-get update -qq
if ! $sudo apt-get install -y -qq --no-install-recommends "${missing[@]}"; then
  # Seen here: Debian's lammps and liggghts pull in python3-paraview, which conflicts with the
  # python3-vtk9 that libvtk9-dev needs.
  if dpkg-query -W -f='${Status}' python3-paraview 2>/dev/null | grep -q "install ok installed"; then
    echo "install-deps: python3-paraview (installed with Debian's lammps/liggghts) conflicts with" \
      "libvtk9-dev; remove it first: apt-get remove python3-paraview" >&2
  fi
  exit 1
fi
