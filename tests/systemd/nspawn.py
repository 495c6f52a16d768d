"""A Debian system under a real systemd, for the tests that install the packages.

- build_debs(): the .debs of a source tree, with packaging/build-deb; on this
  host, or inside a container of another Debian release (`in_suite`).
- previous_debs(): the last release's packages (a pinned commit, its changelog
  version set below this tree's), built once and cached.
- rootfs(): a minimal Debian (systemd, apt, the packages' run-time dependencies)
  made with mmdebstrap, cached as a tarball keyed by the suite and the package
  list, and remade after a week.
- Container: that tarball unpacked and booted with systemd-nspawn (systemd as
  PID 1, its own network namespace: no DDS traffic or port 8035 shared with the
  host or other tests); commands go in with nsenter.
- stage(): another release's packages and system, once for every test that
  needs them (`python3 nspawn.py stage trixie DIR`, a ctest fixture): DIR/debs,
  DIR/root (that release's system with its daemon unpacked) and DIR/rs-discoveryd,
  which runs that daemon on this host with its own loader and libraries, so the
  interop tests run unchanged against it.

Used by test_real_systemd.py and by run-real-systemd (the trixie run).
"""
import hashlib
import os
import re
import shutil
import signal
import subprocess
import tempfile
import time

SOURCE_DIR = os.environ.get("RSD_SOURCE_DIR", os.path.abspath(os.path.join(os.path.dirname(__file__), "..", "..")))
CACHE_DIR = os.environ.get("RSD_CACHE_DIR") or os.path.join(
    os.environ.get("XDG_CACHE_HOME") or os.path.expanduser("~/.cache"), "rs-discoveryd")
ROOTFS_MAX_AGE = 7 * 24 * 3600  # a week-old rootfs is made anew (security updates)
CONTAINER_PATH = "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin"

# The release the upgrade test starts from: the last commit whose packages were
# rs-discoveryd (daemon and CLI in one), librsdiscovery0 and librsdiscovery-dev.
# Its changelog version is replaced by PREVIOUS_VERSION so that this tree's
# packages are an upgrade of it. Move both on at the next release.
PREVIOUS_COMMIT = "1447030974492fa30cf8f5234b063889bc125b62"
PREVIOUS_VERSION = "0.1.0~prev1"
BUILD_TOOLS = ["build-essential", "debhelper", "dpkg-dev", "fakeroot", "git", "ccache"]
# What the booted system gets: this tree's daemon, CLI and both client libraries
# (the -dev package is checked on the host, by tests/packaging), and the previous
# release's packages to upgrade from.
CURRENT = ["rs-discoveryd", "rs-discover", "librsdiscovery1", "python3-rsdiscovery"]
PREVIOUS = ["rs-discoveryd", "librsdiscovery0"]


def log(msg):
    print(f"[real-systemd {time.strftime('%H:%M:%S')}] {msg}", flush=True)


def sh(*cmd, check=True, timeout=900, **kw):
    r = subprocess.run(cmd, capture_output=True, text=True, timeout=timeout, **kw)
    if check and r.returncode != 0:
        raise RuntimeError(f"{' '.join(cmd)}: exit {r.returncode}\n{r.stdout[-4000:]}\n{r.stderr[-4000:]}")
    return r


def host_has_systemd():
    return os.path.isdir("/run/systemd/system")


def changelog_version(tree):
    with open(os.path.join(tree, "packaging", "debian", "changelog")) as f:
        return re.match(r"\S+ \(([^)]+)\)", f.readline()).group(1)


def set_changelog_version(tree, version):
    path = os.path.join(tree, "packaging", "debian", "changelog")
    text = open(path).read()
    open(path, "w").write(re.sub(r"^(\S+) \([^)]+\)", rf"\1 ({version})", text, count=1))


def debs_in(directory):
    """{package name: path} of the .deb files in directory."""
    out = {}
    for f in sorted(os.listdir(directory)):
        if f.endswith(".deb"):
            out[f.split("_")[0]] = os.path.join(directory, f)
    return out


def build_debs(tree, out, suite=None, env=None):
    """packaging/build-deb of `tree` into `out`; on this host, or inside a minimal
    Debian `suite` container (its build dependencies installed there)."""
    os.makedirs(out, exist_ok=True)
    t0 = time.monotonic()
    env = dict(env or {}, RSD_DEB_JOBS=os.environ.get("RSD_DEB_JOBS", "2"))
    if suite is None:
        sh(os.path.join(tree, "packaging", "build-deb"), out, timeout=2400, env=dict(os.environ, **env))
    else:
        # The container's compiler cache is kept beside the rootfs, one per suite
        # (build-deb's RSD_DEB_CCACHE): the build of the last run serves this one.
        cache = os.path.join(CACHE_DIR, "ccache", suite)
        os.makedirs(cache, exist_ok=True)
        env.update(RSD_DEB_CCACHE="1", CCACHE_DIR="/ccache")
        root = Container(rootfs(suite, BUILD_TOOLS + build_depends(tree)), name="rsd-build")
        try:
            r = subprocess.run(
                ["systemd-nspawn", "-q", "-D", root.dir, "--private-network", *nspawn_register_args(),
                 f"--bind-ro={tree}:/src", f"--bind={out}:/out", f"--bind={cache}:/ccache", "--chdir=/src",
                 *[f"--setenv={k}={v}" for k, v in env.items()],
                 "/src/packaging/build-deb", "/out"],
                capture_output=True, text=True, timeout=2400, stdin=subprocess.DEVNULL)
            if r.returncode != 0:
                raise RuntimeError(f"build-deb in {suite}: exit {r.returncode}\n{r.stdout[-6000:]}\n{r.stderr[-3000:]}")
        finally:
            root.remove()
    log(f"build-deb {tree} ({suite or 'host'}): {time.monotonic() - t0:.0f} s")
    return debs_in(out)


def build_depends(tree):
    """Package names in packaging/debian/control's Build-Depends (first alternatives)."""
    text = open(os.path.join(tree, "packaging", "debian", "control")).read()
    m = re.search(r"^Build-Depends:(.*?)(?=^\S)", text, re.M | re.S)
    names = [re.split(r"[\s(\[<]", alt.split("|")[0].strip())[0] for alt in m.group(1).split(",") if alt.strip()]
    # Virtual packages apt will not pick for mmdebstrap: the real ones.
    real = {"debhelper-compat": "debhelper", "dh-sequence-python3": "dh-python"}
    return sorted({real.get(n, n) for n in names if n in real or not n.startswith("dh-sequence-")})


def previous_debs(suite=None):
    """The previous release's packages (PREVIOUS_COMMIT at PREVIOUS_VERSION), built
    once per suite and kept under the cache directory."""
    out = os.path.join(CACHE_DIR, "debs", f"{suite or host_suite()}-{PREVIOUS_COMMIT[:12]}-{PREVIOUS_VERSION}")
    if os.path.isdir(out) and "rs-discoveryd" in debs_in(out):
        log(f"previous release: cached in {out}")
        return debs_in(out)
    if sh("git", "-C", SOURCE_DIR, "cat-file", "-e", f"{PREVIOUS_COMMIT}^{{commit}}", check=False).returncode != 0:
        raise RuntimeError(f"commit {PREVIOUS_COMMIT} (the previous release) is not in this clone: fetch the history "
                           "(git fetch --unshallow)")
    with tempfile.TemporaryDirectory(prefix="rsd-previous-") as tmp:
        tree = os.path.join(tmp, "rs-discoveryd")
        os.makedirs(tree)
        archive = subprocess.Popen(["git", "-C", SOURCE_DIR, "archive", PREVIOUS_COMMIT], stdout=subprocess.PIPE)
        sh("tar", "-x", "-C", tree, stdin=archive.stdout)
        archive.wait()
        set_changelog_version(tree, PREVIOUS_VERSION)
        partial = f"{out}.{os.getpid()}.partial"
        shutil.rmtree(partial, ignore_errors=True)
        # That release links cpp-httplib without OpenSSL, which httplib 0.18's
        # headers call (trixie, where the linker drops unneeded libraries given
        # before the objects): the linker is given it from outside.
        try:
            build_debs(tree, partial, suite, env={"DEB_LDFLAGS_APPEND": "-Wl,--no-as-needed -lssl -lcrypto"} if suite else None)
            shutil.rmtree(out, ignore_errors=True)
            os.rename(partial, out)
        finally:
            shutil.rmtree(partial, ignore_errors=True)
    return debs_in(out)


def host_suite():
    with open("/etc/os-release") as f:
        m = re.search(r"^VERSION_CODENAME=(\S+)", f.read(), re.M)
    return m.group(1) if m else "unknown"


def run_depends(debs):
    """What the .debs need at run time, other than each other: the names (first
    alternatives) in their Depends and Pre-Depends."""
    ours = set(debs)
    names = set()
    for path in debs.values():
        for field in ("Depends", "Pre-Depends"):
            value = sh("dpkg-deb", "-f", path, field).stdout.strip()
            for dep in filter(None, (d.strip() for d in value.split(","))):
                name = re.split(r"[\s(:]", dep.split("|")[0].strip())[0]
                if name not in ours:
                    names.add(name)
    return sorted(names)


def system_rootfs(suite, current, previous):
    """The booted system's tarball: every run-time dependency of the CURRENT and
    PREVIOUS packages. One cache key for the real-systemd test and stage()."""
    wanted = {p: current[p] for p in CURRENT}
    old = {p: previous[p] for p in PREVIOUS}
    return rootfs(suite, run_depends({**wanted, **old}))


def rootfs(suite, packages):
    """A tarball of a minimal Debian `suite` with systemd and `packages`, cached
    under CACHE_DIR/rootfs by suite and package list. Only ever unpacked into a
    fresh directory, so one cached tarball serves every run."""
    packages = sorted(set(["systemd", "systemd-sysv", "dbus", "curl", "ca-certificates"] + list(packages)))
    key = hashlib.sha256((suite + "\n" + "\n".join(packages)).encode()).hexdigest()[:16]
    directory = os.path.join(CACHE_DIR, "rootfs")
    os.makedirs(directory, exist_ok=True)
    tar = os.path.join(directory, f"{suite}-{key}.tar")
    for f in os.listdir(directory):  # stale ones of any key go
        p = os.path.join(directory, f)
        if time.time() - os.path.getmtime(p) > ROOTFS_MAX_AGE:
            os.remove(p)
    if os.path.exists(tar):
        log(f"rootfs {suite}: cached {tar}")
        return tar
    t0 = time.monotonic()
    partial = f"{tar}.{os.getpid()}.partial"
    try:
        sh("mmdebstrap", "--quiet", "--variant=apt", "--format=tar", f"--include={','.join(packages)}",
           # Quiet, small, and a machine-id made at first boot.
           "--dpkgopt=path-exclude=/usr/share/{doc,man,locale}/*", "--dpkgopt=path-include=/usr/share/doc/*/copyright",
           "--customize-hook=rm -f \"$1\"/etc/machine-id \"$1\"/var/lib/dbus/machine-id; echo uninitialized > \"$1\"/etc/machine-id",
           "--customize-hook=echo rsd-test > \"$1\"/etc/hostname",
           suite, partial, timeout=1800)
        os.rename(partial, tar)
    finally:
        if os.path.exists(partial):
            os.remove(partial)
    log(f"rootfs {suite}: made in {time.monotonic() - t0:.0f} s ({len(packages)} packages asked for)")
    return tar


def nspawn_register_args():
    # Without a systemd on the host there is no bus to register a machine or a
    # scope with: stay in the caller's cgroup.
    return [] if host_has_systemd() else ["--register=no", "--keep-unit"]


def _child_pids(pid):
    out = []
    try:
        for tid in os.listdir(f"/proc/{pid}/task"):
            with open(f"/proc/{pid}/task/{tid}/children") as f:
                out += [int(p) for p in f.read().split()]
    except FileNotFoundError:
        pass
    return out


class Container:
    """A rootfs tarball unpacked into a fresh directory, booted on demand."""

    def __init__(self, tar, name="rsd-systemd", binds=()):
        self.name = f"{name}-{os.getpid()}"
        self.dir = tempfile.mkdtemp(prefix=f"{name}-", dir=os.environ.get("RSD_CONTAINER_DIR"))
        self.binds = list(binds)
        self.nspawn = None
        self.pid1 = None
        self.console = None
        sh("tar", "-x", "-C", self.dir, "-f", tar, timeout=300)

    def boot(self, timeout=60):
        """Boots and returns once systemd says the system is up; the time it took."""
        t0 = time.monotonic()
        self.console = open(os.path.join(os.path.dirname(self.dir), f"{os.path.basename(self.dir)}.console"), "ab")
        cmd = ["systemd-nspawn", "-D", self.dir, "--boot", "--private-network", f"--machine={self.name}",
               "--console=passive", *nspawn_register_args()]
        cmd += [f"--bind-ro={host}:{guest}" for host, guest in self.binds]
        self.nspawn = subprocess.Popen(cmd, stdin=subprocess.DEVNULL, stdout=self.console,
                                       stderr=subprocess.STDOUT, start_new_session=True)
        deadline = t0 + timeout
        while not self.pid1:
            if self.nspawn.poll() is not None:
                raise RuntimeError(f"systemd-nspawn exited {self.nspawn.returncode}: see {self.console.name}")
            if time.monotonic() > deadline:
                raise RuntimeError("systemd-nspawn started no PID 1")
            kids = _child_pids(self.nspawn.pid)
            if kids and os.path.exists(f"/proc/{kids[0]}/ns/pid") and \
                    os.readlink(f"/proc/{kids[0]}/ns/pid") != os.readlink("/proc/self/ns/pid"):
                self.pid1 = kids[0]
            else:
                time.sleep(0.05)
        while True:  # until systemctl can talk to PID 1, then until the boot is over
            r = self.run("systemctl", "is-system-running", "--wait", check=False, timeout=timeout)
            state = r.stdout.strip()
            if state in ("running", "degraded"):
                break
            if time.monotonic() > deadline:
                raise RuntimeError(f"the container did not finish booting: {state!r} {r.stderr}")
            time.sleep(0.1)
        if state == "degraded":
            failed = self.run("systemctl", "--failed", "--no-legend", check=False).stdout
            raise RuntimeError(f"the container booted degraded: {failed}")
        return time.monotonic() - t0

    def run(self, *cmd, check=True, timeout=120, input=None, env=None):
        """A command inside the container (all its namespaces, its root)."""
        e = {"PATH": CONTAINER_PATH, "LANG": "C.UTF-8", "SYSTEMD_PAGER": "", "SYSTEMD_COLORS": "0",
             "DEBIAN_FRONTEND": "noninteractive", "TERM": "dumb"}
        e.update(env or {})
        r = subprocess.run(["nsenter", "-t", str(self.pid1), "-a", "--", *cmd], capture_output=True, text=True,
                           timeout=timeout, input=input if input is not None else "", env=e)
        if check and r.returncode != 0:
            raise AssertionError(f"in the container: {' '.join(cmd)}: exit {r.returncode}\n"
                                 f"{r.stdout[-4000:]}\n{r.stderr[-4000:]}")
        return r

    def sh(self, script, **kw):
        return self.run("sh", "-ec", script, **kw)

    def popen(self, script):
        return subprocess.Popen(["nsenter", "-t", str(self.pid1), "-a", "--", "sh", "-c", script],
                                stdin=subprocess.DEVNULL, stdout=subprocess.PIPE, stderr=subprocess.STDOUT,
                                text=True, env={"PATH": CONTAINER_PATH, "LANG": "C.UTF-8"})

    def poweroff(self, timeout=60):
        """A clean shutdown (SIGTERM to nspawn: it asks PID 1 to power off)."""
        if self.nspawn and self.nspawn.poll() is None:
            self.nspawn.send_signal(signal.SIGTERM)
            try:
                self.nspawn.wait(timeout)
            except subprocess.TimeoutExpired:
                self.nspawn.kill()
                self.nspawn.wait()
        self.nspawn = None
        self.pid1 = None
        if self.console:
            self.console.close()
            self.console = None

    def remove(self):
        self.poweroff()
        shutil.rmtree(self.dir, ignore_errors=True)
        console = os.path.join(os.path.dirname(self.dir), f"{os.path.basename(self.dir)}.console")
        if os.path.exists(console):
            os.remove(console)


def stage(suite, out):
    """`suite`'s packages of this tree in out/debs (built in a container of that
    release), its system (the real-systemd test's rootfs, so one cache serves
    both) in out/root with the daemon's package unpacked into it, and
    out/rs-discoveryd: that daemon run on this host by its own release's loader
    and libraries (Cyclone DDS, libusb, libsystemd, cpp-httplib), with this host's
    files, sockets and network namespaces. Not a chroot: a test's socket and
    config paths mean the same to it as to the test."""
    debs_dir, root = os.path.join(out, "debs"), os.path.join(out, "root")
    shutil.rmtree(out, ignore_errors=True)
    t0 = time.monotonic()
    current = build_debs(SOURCE_DIR, debs_dir, suite)
    previous = previous_debs(suite)
    tar = system_rootfs(suite, current, previous)
    os.makedirs(root)
    sh("tar", "-x", "-C", root, "-f", tar, timeout=300)
    sh("dpkg-deb", "-x", current["rs-discoveryd"], root)
    libdir = "usr/lib/x86_64-linux-gnu"
    wrapper = os.path.join(out, "rs-discoveryd")
    with open(wrapper, "w") as f:
        f.write(f"""#!/bin/sh
# rs-discoveryd as packaged for {suite}, run by {suite}'s own loader and libraries
# (nspawn.py stage). exec keeps the PID: signals reach the daemon itself.
root=$(dirname "$0")/root
exec "$root/{libdir}/ld-linux-x86-64.so.2" --library-path "$root/{libdir}" "$root/usr/sbin/rs-discoveryd" "$@"
""")
    os.chmod(wrapper, 0o755)
    version = sh(wrapper, "--version").stdout.strip()
    cyclone = [os.path.basename(p) for p in os.listdir(os.path.join(root, libdir)) if p.startswith("libddsc.so.")]
    log(f"stage {suite}: {version}, {sorted(cyclone)}, in {time.monotonic() - t0:.0f} s")


if __name__ == "__main__":
    import sys
    if len(sys.argv) != 4 or sys.argv[1] != "stage":
        sys.exit("usage: nspawn.py stage SUITE DIR")
    stage(sys.argv[2], os.path.abspath(sys.argv[3]))
