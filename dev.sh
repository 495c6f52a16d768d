#!/usr/bin/env bash
# rs-discoveryd developer entry point: the two commands the README gives.
#
#   ./dev.sh run    install what building and running need, build the daemon,
#                   rs-discover and the client library, run the daemon in the foreground
#                   on its embedded defaults (domain 0, HTTP on 127.0.0.1:8035, Unix
#                   socket under the runtime directory); extra arguments go to the
#                   daemon, e.g. ./dev.sh run --domain 5
#   ./dev.sh build [DIR]   the same build, in DIR (default build), without running:
#                   then `cmake --install DIR --prefix P` installs everything
#   ./dev.sh test   install everything the tests need too, build (plain, and with
#                   AddressSanitizer and UBSan), and run the whole test suite with
#                   ctest on both; also the fuzz targets under libFuzzer (clang) and
#                   the daemon's threads under ThreadSanitizer
#   ./dev.sh packages run|test   print the Debian packages that command installs
#
# Needs Debian bookworm (or newer) and root, or sudo, for apt-get.
set -euo pipefail
cd "$(dirname "$0")"
ROOT=$PWD

# What building and running need: `./dev.sh run` installs only these.
RUN_PACKAGES=(
  build-essential cmake ninja-build pkg-config
  cyclonedds-dev cyclonedds-tools libusb-1.0-0-dev nlohmann-json3-dev libcpp-httplib-dev rapidjson-dev libsystemd-dev
)
# What the test suite needs on top: `./dev.sh test` installs these too.
TEST_PACKAGES=(
  git googletest libgtest-dev libgmock-dev
  # a Python for the harnesses and the real realdds peer (pyrealsense2 needs libusb)
  python3 python3-venv python3-pip python3-gi curl libusb-1.0-0 iproute2 groff-base util-linux
  # the network-cut and doctor tests: firewall rules in network namespaces
  nftables
  # USB tests with emulated devices
  umockdev libumockdev-dev gir1.2-umockdev-1.0
  # systemd tools (systemd-socket-activate, systemd-analyze) and Debian packaging
  systemd debhelper devscripts lintian fakeroot dpkg-dev
  # the systemd tests trace the daemon's system calls against the unit's filter
  strace
  # the Python client's package (python3-rsdiscovery), built by packaging/build-deb
  dh-python pybuild-plugin-pyproject python3-all python3-setuptools python3-wheel
  # the real-systemd test: a minimal Debian booted with systemd-nspawn
  mmdebstrap systemd-container
  # bench/run (and its smoke test): load generators and the nginx anchor
  wrk nginx-light
  # the fuzz targets under libFuzzer (tests/fuzz; a third tree, build-fuzz)
  clang libclang-rt-dev
  # the daemon's web page, tested in a real headless browser
  chromium chromium-driver
  # rs-discover's shell completions, tested in the shells themselves
  bash-completion zsh
  # the man pages, linted (groff-base above renders them)
  mandoc
  # reading the man pages from the tree, as the README says (man -l)
  man-db
  # the suite compiles the tree four times over and twice more in fresh trees
  # (client_first_run, the packages): a compiler cache makes the repeats cheap
  ccache
)
DEB_PACKAGES=("${RUN_PACKAGES[@]}" "${TEST_PACKAGES[@]}")

# What `run` builds: what runs, and what `cmake --install` installs besides (the C++
# library; its objects are rs-discover's too, so it costs a link), not the tests.
RUN_TARGETS=(rs-discoveryd rs-discover rsdiscovery rsdiscovery_static)

say() { printf '\n==> %s\n' "$*"; }

as_root() { if [ "$(id -u)" -eq 0 ]; then "$@"; else sudo "$@"; fi; }

install_packages() {  # install_packages PACKAGE...: those of them not installed yet
  local missing=()
  for p in "$@"; do
    dpkg-query -W -f='${Status}' "$p" 2>/dev/null | grep -q "install ok installed" || missing+=("$p")
  done
  if [ ${#missing[@]} -gt 0 ]; then
    say "installing Debian packages: ${missing[*]}"
    as_root apt-get update -q
    DEBIAN_FRONTEND=noninteractive as_root apt-get install -y -q --no-install-recommends "${missing[@]}"
  fi
}

python_env() {
  # Debian's python3 with its site-packages visible: the umockdev tests need its GI bindings.
  if [ ! -x .venv/bin/python ]; then
    say "creating the test Python environment in .venv"
    /usr/bin/python3 -m venv --system-site-packages .venv
  fi
  if ! cmp -s tests/requirements.txt .venv/.requirements 2>/dev/null; then
    say "installing Python test requirements"
    .venv/bin/pip install -q --disable-pip-version-check -r tests/requirements.txt
    cp tests/requirements.txt .venv/.requirements
  fi
}

configure() {  # configure DIR [cmake args...]; later arguments win
  local dir=$1 cache=()
  shift
  if command -v ccache >/dev/null; then
    # Through ccache where it is installed (`test` installs it). Paths relative to
    # the tree, and the build directory left out of the hash: a second build
    # directory or a fresh clone elsewhere hits the same entries (their debug
    # info then names the first directory).
    export CCACHE_BASEDIR=${CCACHE_BASEDIR:-$ROOT} CCACHE_NOHASHDIR=${CCACHE_NOHASHDIR:-1}
    cache=(-DCMAKE_C_COMPILER_LAUNCHER=ccache -DCMAKE_CXX_COMPILER_LAUNCHER=ccache)
  fi
  cmake -S . -B "$dir" -G Ninja -DCMAKE_BUILD_TYPE=RelWithDebInfo -DRSD_WERROR=ON "${cache[@]}" "$@" >/dev/null
}

build() {  # build DIR [cmake args...]: every target, tests included
  local dir=$1
  say "building in $dir"
  configure "$@"
  cmake --build "$dir" -j"$(nproc)"
}

build_targets() {  # build_targets DIR "TARGET..." [cmake args...]: only these targets
  local dir=$1 targets=$2
  shift 2
  say "building $targets in $dir"
  configure "$dir" "$@"
  # shellcheck disable=SC2086  # the targets are words
  cmake --build "$dir" -j"$(nproc)" --target $targets
}

case "${1:-}" in
  packages)
    # The Debian packages each command installs (what `run` needs is a part of `test`'s).
    case "${2:-}" in
      run) printf '%s\n' "${RUN_PACKAGES[@]}" ;;
      test) printf '%s\n' "${DEB_PACKAGES[@]}" ;;
      *) echo "usage: ./dev.sh packages run|test" >&2; exit 2 ;;
    esac
    ;;
  run | build)
    command=$1
    shift
    dir=build
    if [ "$command" = build ] && [ $# -gt 0 ]; then dir=$1; fi
    install_packages "${RUN_PACKAGES[@]}"
    say "building ${RUN_TARGETS[*]} in $dir"
    # The test suite needs GoogleTest, which only `./dev.sh test` installs: a tree
    # that has it keeps its tests configured, a first run builds without them.
    tests=OFF
    if dpkg-query -W -f='${Status}' libgtest-dev 2>/dev/null | grep -q "install ok installed"; then tests=ON; fi
    configure "$dir" -DRSD_BUILD_TESTS=$tests
    cmake --build "$dir" -j"$(nproc)" --target "${RUN_TARGETS[@]}"
    if [ "$command" = build ]; then exit 0; fi
    say "starting rs-discoveryd (Ctrl-C stops it); rs-discover is build/client/rs-discover"
    exec build/daemon/rs-discoveryd "$@"
    ;;
  test)
    install_packages "${DEB_PACKAGES[@]}"
    python_env
    build build -DRSD_BUILD_TESTS=ON
    # -O1: what ASan is meant for, and the second tree compiles in half the time.
    build build-asan -DRSD_SANITIZE=ON -DCMAKE_BUILD_TYPE=Debug -DCMAKE_C_FLAGS_DEBUG="-O1 -g1" \
      -DCMAKE_CXX_FLAGS_DEBUG="-O1 -g1"
    # libFuzzer binaries (clang, ASan + UBSan): only the fuzz targets and what they link.
    build_targets build-fuzz "fuzz_device_info fuzz_request fuzz_api_values fuzz_config fuzz_shared_usb fuzz_ros_discovery fuzz_client_documents" \
      -DCMAKE_C_COMPILER=clang -DCMAKE_CXX_COMPILER=clang++ -DRSD_LIBFUZZER=ON -DRSD_SANITIZE=ON -DRSD_BUILD_CLIENT=ON
    # ThreadSanitizer (tests/tsan/README.md): the daemon and the API harness (and the CLI
    # some of those suites drive; its own threads are not what is looked at).
    build_targets build-tsan "rs-discoveryd api_harness rs-discover" -DRSD_TSAN=ON
    status=0
    say "fuzzing: each target replays its corpus, then runs for a few seconds"
    ctest --test-dir build-fuzz -L fuzz --output-on-failure || status=1
    say "test suite, plain build"
    # Most tests wait on DDS discovery and leases, not the CPU: three at a time.
    ctest --test-dir build -j3 --output-on-failure --timeout 600 || status=1
    say "the daemon's threads under ThreadSanitizer"
    # ignore_noninstrumented_modules: what Debian's uninstrumented libraries (Cyclone,
    # libusb) do between their own threads is invisible to TSan but for their calls
    # into libc, which it would take for races (tests/tsan/README.md).
    TSAN_OPTIONS="halt_on_error=1:exitcode=66:ignore_noninstrumented_modules=1:suppressions=$ROOT/tests/tsan/suppressions.txt" \
    RSD_SOAK_SECONDS=30 \
      ctest --test-dir build-tsan -j3 --output-on-failure --timeout 600 \
      -R '^(api_harness|api_abuse|api_daemon|daemon_lifecycle|interop_realdds|interop_describe|interop_participants|usb_hotplug|share_usb|share_agree|systemd_reload|soak)$' \
      || status=1
    say "test suite, AddressSanitizer + UBSan build"
    # A sanitizer finding makes the binary exit non-zero, which fails its test.
    # umockdev preloads its library ahead of ASan's runtime: allowed explicitly.
    # client_first_run builds a fresh plain tree of its own whichever tree runs it:
    # the plain run above has done it, a second one would only cost the minutes.
    ASAN_OPTIONS=detect_leaks=1:halt_on_error=1:verify_asan_link_order=0 \
    UBSAN_OPTIONS=print_stacktrace=1:halt_on_error=1 \
      ctest --test-dir build-asan -j3 --output-on-failure --timeout 900 -E '^client_first_run$' || status=1
    exit $status
    ;;
  *)
    sed -n '2,16p' "$0" | sed 's/^# \{0,1\}//'
    exit 2
    ;;
esac
