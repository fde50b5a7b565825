#!/usr/bin/env bash
# setup.sh: install the Debian 12 packages dtx needs to build, test and run.
#
# Usage: scripts/setup.sh
#
# Checks every package with dpkg-query and installs only the missing ones
# (apt-get update first, and only then). Needs root for that: runs apt-get
# through sudo when not root. When everything is present it prints one line and
# takes well under a second. The Python packages (used by helper scripts, not by
# the build) are optional: failing to install them is a warning, not an error.
# So is the glTF validator (npm, into build-tools/; needs node and npm).
set -euo pipefail

die() { echo "setup: error: $*" >&2; exit 1; }

required=(build-essential cmake pkg-config libopenmpi-dev openmpi-bin libhdf5-openmpi-dev
          hdf5-tools libsuitesparse-dev libopenblas-dev liblapack-dev libcjson-dev libpng-dev
          xz-utils valgrind libassimp-dev)
optional=(python3-h5py python3-numpy assimp-utils)

command -v dpkg-query > /dev/null || die "dpkg-query not found: this script is for Debian 12"

# One dpkg-query for all packages; a package dpkg has never heard of is simply
# absent from the output (dpkg-query then complains on stderr and exits 1).
declare -A installed=()
while read -r pkg status; do
    if [[ $status == "install ok installed" ]]; then installed[${pkg%%:*}]=1; fi
done < <(dpkg-query -W -f='${Package} ${Status}\n' "${required[@]}" "${optional[@]}" \
             2> /dev/null || true)

missing_req=()
missing_opt=()
for p in "${required[@]}"; do [[ -n ${installed[$p]:-} ]] || missing_req+=("$p"); done
for p in "${optional[@]}"; do [[ -n ${installed[$p]:-} ]] || missing_opt+=("$p"); done

# The Khronos glTF validator (npm package gltf-validator), used only by the
# test of `dtx export --glb`; installed into build-tools/ in the source tree
# (ignored by git) when node and npm are present. Optional: without it that test
# is skipped, so a failure here is a warning.
gltf_validator() {
    local dir
    dir=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/build-tools
    [[ -f $dir/node_modules/gltf-validator/package.json ]] && return 0
    command -v node > /dev/null && command -v npm > /dev/null || return 0
    echo "setup: installing gltf-validator (npm) into $dir"
    mkdir -p "$dir" && npm install --prefix "$dir" --no-audit --no-fund --silent --fetch-retries=1 \
        gltf-validator@2.0.0-dev.3.10 < /dev/null > /dev/null ||
        echo "setup: warning: npm install gltf-validator failed; its test will be skipped" >&2
}
gltf_validator

missing=("${missing_req[@]}" "${missing_opt[@]}")
if [[ ${#missing[@]} -eq 0 ]]; then
    echo "setup: all dependencies present"
    exit 0
fi

if [[ $(id -u) -eq 0 ]]; then
    as_root=()
elif command -v sudo > /dev/null; then
    as_root=(sudo)
else
    die "missing packages (${missing[*]}); run this script as root or install sudo"
fi

apt_install() {
    "${as_root[@]}" env DEBIAN_FRONTEND=noninteractive \
        apt-get -q install -y --no-install-recommends "$@" < /dev/null
}

echo "setup: installing: ${missing[*]}"
"${as_root[@]}" apt-get -q update < /dev/null || die "apt-get update failed"
if [[ ${#missing_req[@]} -gt 0 ]]; then
    apt_install "${missing_req[@]}" || die "apt-get install ${missing_req[*]} failed"
fi
if [[ ${#missing_opt[@]} -gt 0 ]]; then
    apt_install "${missing_opt[@]}" ||
        echo "setup: warning: could not install optional ${missing_opt[*]}" >&2
fi
echo "setup: done"
