#!/usr/bin/env bash
# Installs every Debian 12 package Penumbra needs to build, run and test.
# Idempotent: when everything is present it installs nothing and touches no package list.
set -euo pipefail

packages=(
  build-essential cmake ninja-build pkg-config git ccache clang libclang-rt-dev
  libvulkan-dev mesa-vulkan-drivers vulkan-validationlayers vulkan-tools
  glslang-dev glslang-tools spirv-tools libspirv-cross-c-shared-dev
  libglfw3-dev libglm-dev libtinygltf-dev libopenmesh-dev libstb-dev
  nlohmann-json3-dev libcli11-dev libspdlog-dev libfmt-dev
  libgtest-dev libgmock-dev libbenchmark-dev
  libembree-dev libtbb-dev libxxhash-dev libimgui-dev libopenexr-dev xvfb xauth python3-jsonschema
  assimp-testmodels
  # ImageMagick with its own SVG renderer and OpenEXR coder (the -extra coders), and
  # librsvg: the readers that pareto.svg and the visibility EXR are tested with; the URW
  # fonts are the ones ImageMagick's SVG coder draws sans-serif with (Helvetica's metrics:
  # without them it refuses the plot's text)
  imagemagick libmagickcore-6.q16-6-extra librsvg2-bin fonts-urw-base35
)

missing=()
for p in "${packages[@]}"; do
  if ! dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed"; then
    missing+=("$p")
  fi
done

if [ ${#missing[@]} -eq 0 ]; then
  echo "install-deps: all ${#packages[@]} packages present"
  exit 0
fi

sudo_cmd=()
if [ "$(id -u)" -ne 0 ]; then
  if command -v sudo >/dev/null 2>&1; then
    sudo_cmd=(sudo)
  else
    echo "install-deps: need root (or sudo) to install: ${missing[*]}" >&2
    exit 1
  fi
fi

echo "install-deps: installing ${missing[*]}"
"${sudo_cmd[@]}" apt-get update -q
DEBIAN_FRONTEND=noninteractive "${sudo_cmd[@]}" apt-get install -y -q --no-install-recommends "${missing[@]}"
