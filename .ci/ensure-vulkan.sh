#!/usr/bin/env bash
# Makes sure a Vulkan driver is present: wgpu needs the Vulkan loader
# (libvulkan.so.1) and at least one ICD. On a machine without a GPU this
# installs Mesa's lavapipe CPU driver (Debian/Ubuntu: mesa-vulkan-drivers).
set -euo pipefail

# Off Linux wgpu has a native backend and needs no Vulkan driver (issue 67
# item 8: this script stopped `make run` and `make test` on macOS).
case "$(uname -s)" in
    Darwin)
        echo "macOS: wgpu renders through Metal, the native adapter (no Vulkan driver needed; 'mdas info' names it)" >&2
        exit 0 ;;
    MINGW* | MSYS* | CYGWIN* | Windows_NT)
        echo "Windows: wgpu renders through Direct3D 12 or the GPU vendor's Vulkan driver ('mdas info' names the adapter)" >&2
        exit 0 ;;
esac

# The loader: ldconfig's cache where there is one (grep reads all of its
# output, not -q: with pipefail, a grep that exits at the first match can
# kill ldconfig with SIGPIPE and fail the test), else the usual library
# directories (ldconfig lives in /sbin, often not on a user's PATH, and
# some distributions have none).
have_loader() {
    if command -v ldconfig >/dev/null 2>&1 \
        && ldconfig -p 2>/dev/null | grep 'libvulkan\.so\.1' >/dev/null; then
        return 0
    fi
    local d
    for d in ${LD_LIBRARY_PATH:+${LD_LIBRARY_PATH//:/ }} /usr/lib/x86_64-linux-gnu /usr/lib/aarch64-linux-gnu \
        /usr/lib64 /usr/lib /usr/local/lib /lib64 /lib; do
        [ -e "$d/libvulkan.so.1" ] && return 0
    done
    return 1
}
have_icd() {
    local d
    for d in /usr/share/vulkan/icd.d /etc/vulkan/icd.d /usr/local/share/vulkan/icd.d; do
        compgen -G "$d/*.json" >/dev/null && return 0
    done
    [ -n "${VK_ICD_FILENAMES:-}${VK_DRIVER_FILES:-}" ]
}

if have_loader && have_icd; then
    exit 0
fi

echo "No Vulkan driver found: installing Mesa's Vulkan drivers (lavapipe)..." >&2
if command -v apt-get >/dev/null 2>&1; then
    SUDO=""
    if [ "$(id -u)" -ne 0 ]; then
        if command -v sudo >/dev/null 2>&1; then SUDO="sudo"; else
            echo "error: need root to run apt-get; install mesa-vulkan-drivers and libvulkan1 yourself" >&2
            exit 1
        fi
    fi
    export DEBIAN_FRONTEND=noninteractive
    $SUDO apt-get update -qq
    $SUDO apt-get install -y -qq mesa-vulkan-drivers libvulkan1 >/dev/null
else
    echo "error: no Vulkan driver and no apt-get. Install a Vulkan driver: Mesa's lavapipe" \
         "(package mesa-vulkan-drivers / vulkan-swrast / mesa-vulkan-swrast) or your GPU vendor's." >&2
    exit 1
fi

if ! (have_loader && have_icd); then
    echo "error: installed mesa-vulkan-drivers but still no Vulkan loader/ICD found" >&2
    exit 1
fi
