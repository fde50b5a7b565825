#!/usr/bin/env bash
# setup.sh: install the Debian 12 packages dtx needs to build, test and run.
#
# Usage: scripts/setup.sh
#
# Checks every package with dpkg-query and installs only the missing ones
# (apt-get update first, and only then). Needs root for that: runs apt-get
# through sudo when not root. When everything is present it prints one line and
# takes well under a second. The optional list (a failure to install is a
# warning) is empty today: Debian's python3-h5py and python3-numpy are required,
# since io.layout_doc_example and cli.export read results with them.
# Everything a CI test needs is required: Debian's blender (cli.blender),
# chromium (the browser workbench), nodejs and npm (only when node/npm are not
# already on PATH, e.g. from nodesource), libassimp-dev (glTF/FBX import), clang
# and libclang-rt-14-dev (the fuzzers), Slurm's slurmctld, slurmd and slurm-client
# (cli.slurm starts a one-node cluster of its own, with auth/none: no munge);
# then npm packages, pinned, into build-tools/ (ignored by git): gltf-validator (cli.gltf_validator), three and
# puppeteer-core (which downloads no browser; it drives Debian's chromium).
set -euo pipefail

die() { echo "setup: error: $*" >&2; exit 1; }

required=(build-essential cmake pkg-config libopenmpi-dev openmpi-bin libhdf5-openmpi-dev
          hdf5-tools libsuitesparse-dev libopenblas-dev liblapack-dev libcjson-dev libpng-dev
          xz-utils valgrind blender chromium libassimp-dev clang libclang-rt-14-dev
          python3-h5py python3-numpy slurmctld slurmd slurm-client)
# Debian's nodejs and npm only when no node/npm is on PATH (a nodesource node
# ships its own npm and conflicts with Debian's npm package).
command -v node > /dev/null || required+=(nodejs)
command -v npm > /dev/null || required+=(npm)
optional=(assimp-utils)

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


# npm packages (pinned) into build-tools/ in the source tree: the Khronos glTF
# validator, three (compiled into dtx view's pages: cmake must run after it is
# installed) and puppeteer-core (the browser tests; it downloads no browser).
# Checked by the version in their package.json files, so a second run does not
# call npm and a changed pin is installed.  Required: a failure is an error.
npm_tools() {
    local dir p missing=()
    dir=$(cd "$(dirname "${BASH_SOURCE[0]}")/.." && pwd)/build-tools
    for p in gltf-validator@2.0.0-dev.3.10 three@0.160.0 puppeteer-core@21.11.0; do
        grep -qs "\"version\": \"${p##*@}\"" "$dir/node_modules/${p%@*}/package.json" ||
            missing+=("$p")
    done
    [[ ${#missing[@]} -eq 0 ]] && return 0
    command -v npm > /dev/null || die "npm not found after installing packages"
    echo "setup: installing ${missing[*]} (npm) into $dir"
    mkdir -p "$dir" && PUPPETEER_SKIP_DOWNLOAD=1 npm install --prefix "$dir" --no-audit --no-fund \
        --silent --fetch-retries=1 "${missing[@]}" < /dev/null > /dev/null ||
        die "npm install ${missing[*]} failed"
}

missing=("${missing_req[@]}" "${missing_opt[@]}")
if [[ ${#missing[@]} -eq 0 ]]; then
    npm_tools
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
npm_tools
echo "setup: done"
