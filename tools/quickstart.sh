#!/bin/sh
# The README's two commands. On a fresh Debian 12 machine (as root, or with
# sudo) it installs whatever is missing, builds, and then runs:
#   sh tools/quickstart.sh demo   the main job on a generated mesh
#   sh tools/quickstart.sh test   the whole test suite (what CI runs)
set -eu
cd "$(dirname "$0")/.."

mode=${1:-demo}
# (python3-*: the Python package, built and tested by `test` in a venv)
packages="gcc libc6-dev meson ninja-build pkg-config libzstd-dev libpng-dev zstd python3
          python3-dev python3-venv python3-numpy python3-mesonpy python3-pytest"
# (test only: Open MPI, for epsnet-mpi and its test; the plain build needs none of it)
if [ "$mode" = test ]; then packages="$packages openmpi-bin libopenmpi-dev"; fi
missing=""
for p in $packages; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing="$missing $p"
done
if [ -n "$missing" ]; then
    echo "quickstart: installing$missing" >&2
    sudo=""
    [ "$(id -u)" = 0 ] || sudo=sudo
    $sudo apt-get update -qq
    DEBIAN_FRONTEND=noninteractive $sudo apt-get install -y -qq --no-install-recommends $missing >/dev/null
fi

jobs=$(nproc 2>/dev/null || echo 2)

case "$mode" in
demo)
    [ -d build-release ] || meson setup build-release --buildtype=release >/dev/null
    ninja -C build-release >/dev/null
    mkdir -p demo
    bin=build-release/tools/epsnet
    # A scan-like mesh of 1M faces, shuffled like an ordinary scanner PLY.
    [ -f demo/bumpy.ply ] || $bin gen bumpy --faces 1M --seed 7 --shuffle -o demo/bumpy.ply
    # The main job: keep the feature-sensitive samples, drop the rest.
    $bin simplify demo/bumpy.ply -o demo/bumpy_simplified.ply --level 4 --stats demo/stats.json
    $bin sample demo/bumpy.ply -o demo/bumpy_samples.ply --level 4 -q
    echo "outputs in demo/: bumpy_simplified.ply (mesh), bumpy_samples.ply (points), stats.json"
    ;;
test)
    status=0
    # Warnings are errors here (house rule); both suites at the optimisation
    # users get (-O3, where compiler bugs show up) with asserts still on.
    # (-Dmpi=auto: epsnet-mpi and its test `mpi` where Open MPI is installed)
    [ -d build-ci ] || meson setup build-ci -Dwerror=true --buildtype=release -Db_ndebug=false -Dmpi=auto >/dev/null
    ninja -C build-ci >/dev/null
    # The Python package (pyproject.toml, python/) into a venv that sees
    # Debian's numpy and meson-python; its pytest suite is build-ci's test
    # `python` (python/tests/run.py), counted with the others.
    [ -x build-venv/bin/python ] || /usr/bin/python3 -m venv --system-site-packages build-venv
    build-venv/bin/pip install -q --no-build-isolation --no-index --no-deps \
        --config-settings=builddir=build-py --config-settings=setup-args=-Dwerror=true . >/dev/null || status=1
    meson test -C build-ci --num-processes "$jobs" --print-errorlogs || status=1
    # Address and undefined-behaviour sanitizers over the fast suite.
    [ -d build-asan ] || meson setup build-asan -Dwerror=true -Db_sanitize=address,undefined \
        -Db_lundef=false --buildtype=debug -Dslow_tests=false >/dev/null
    ninja -C build-asan >/dev/null
    # The Python package's extension built with the same sanitizers, staged
    # where a venv of its own sees it (a .pth file): build-asan's test
    # `python` runs the pytest suite on it (tests/meson.build).
    [ -x build-venv-asan/bin/python ] || /usr/bin/python3 -m venv --system-site-packages build-venv-asan
    [ -d build-py-asan ] || meson setup build-py-asan -Dpython=true -Dwerror=true \
        -Db_sanitize=address,undefined -Db_lundef=false --buildtype=debug >/dev/null
    ninja -C build-py-asan >/dev/null && meson install -C build-py-asan --quiet --destdir stage >/dev/null &&
        dirname "$(dirname "$(find "$PWD/build-py-asan/stage" -path '*/epsnet/__init__.py' | head -n 1)")" \
            > "$(build-venv-asan/bin/python -c 'import site; print(site.getsitepackages()[0])')/epsnet-asan.pth" ||
        status=1
    meson test -C build-asan --suite fast --num-processes "$jobs" --print-errorlogs || status=1
    # Thread sanitizer over the tests that run threads.
    [ -d build-tsan ] || meson setup build-tsan -Dwerror=true -Db_sanitize=thread -Db_lundef=false \
        --buildtype=debug -Dslow_tests=false >/dev/null
    ninja -C build-tsan tests/test_pool tests/test_hausdorff tests/test_pipeline tests/test_arrays tests/test_peers \
        tests/test_sort tests/test_io_common tests/test_ply tests/test_smz tools/epsnet >/dev/null
    # (of `target`, only its cases through the target stage's rounds and its pricing windows, where
    # its threads meet: CI time)
    TSAN_OPTIONS=halt_on_error=1 \
    EPSNET_TEST_ONLY=a_target_whose_finish_is_over_the_budget_goes_through_rounds_on_slabs,a_long_stream_is_thinned_under_a_ceiling_priced_from_windows \
    EPSNET_PEERS_ONLY=three_ranks_of_two_workers_give_one_process_bytes,a_rank_over_its_budget_stops_every_rank_and_is_named \
        meson test -C build-tsan --no-rebuild pool hausdorff pipeline arrays target peers sort io_common ply smz \
        --num-processes "$jobs" --print-errorlogs || status=1
    exit $status
    ;;
*)
    echo "usage: sh tools/quickstart.sh [demo|test]" >&2
    exit 1
    ;;
esac
