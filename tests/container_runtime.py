"""homcull's container image, built and run with podman as an operator would.

No container registry is reachable from the machines this runs on, but Debian's
packages are, so:

  1. a base image `localhost/debian:bookworm-slim` is bootstrapped from Debian itself
     (`debootstrap --variant=minbase bookworm`, the mirror read from this machine's
     apt sources at run time) and imported, unless it already exists;
  2. deploy/Dockerfile's `runtime` stage is built with `--build-arg BINARY_FROM=prebuilt`
     around the release binary built on this host (same Debian release and glibc; its
     debug info stripped), since no Rust image can be pulled here; users who can pull
     one build the whole Dockerfile;
  3. the image runs as deploy/compose.yaml runs it: its own USER, `--read-only`, a tmpfs
     /tmp, a named volume on /data, all capabilities dropped, no new privileges, the
     port published on 127.0.0.1 only.

The same checks then run against `podman-compose up` of deploy/compose.yaml (the
port published on loopback through HOMCULL_PUBLISH; Debian's podman-compose 1.0.3 is
handed the file with `env_file`'s long syntax rewritten, which it predates). Last,
tests/deploy_runtime.py's scale-out check runs with its three replicas and nginx as
containers on one shared volume (an nginx image built on the same base), a replica
killed mid-stream.

Checks: the image holds no build tools; it runs as UID 10001; its root is read-only and
/data writable; its own HEALTHCHECK passes (`podman healthcheck run`); /readyz names the
backend, the native CPU one, as no GPU is passed in; a cull of the demo answers exactly
what the host binary answers; an uploaded scene survives a restart on the same volume;
SIGTERM (`podman stop`) closes an open WebSocket with 1001 and the container exits 0
within the grace period. The image's size is printed.

podman on these machines needs `--runtime runc --cgroup-manager cgroupfs` (crun refuses
hybrid cgroups) and explicit ulimits (the sandbox forbids raising them); they are set
through a containers.conf of this script's own (CONTAINERS_CONF), so that every podman
call, and podman-compose's, gets them.

Usage: python3 tests/container_runtime.py [--bin PATH]
Exit status: 0 passed; 1 failed; 2 a prerequisite is missing (podman, debootstrap, ...).
Everything listens on 127.0.0.1; every container, volume and process it starts is removed
in a `finally`; the images are kept (a rerun reuses them).
"""

from __future__ import annotations

import argparse
import json
import os
import re
import shutil
import signal
import socket
import subprocess
import sys
import tempfile
import threading
import time
import traceback
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import deploy_runtime as dr  # noqa: E402  (HTTP, WebSocket and process helpers)

REPO = dr.REPO
BASE_IMAGE = "localhost/debian:bookworm-slim"
IMAGE = "localhost/homcull:ci"
TIME_LIMIT_S = 600.0  # bootstrap and build included
CONTAINERS_CONF = """\
[containers]
default_ulimits = ["nofile=1024:1024", "nproc=1024:1024"]

[engine]
runtime = "runc"
cgroup_manager = "cgroupfs"
"""
Failed, Missing, log, expect = dr.Failed, dr.Missing, dr.log, dr.expect


def podman(*args: str, timeout: float = 120, check: bool = True) -> subprocess.CompletedProcess:
    r = subprocess.run(["podman", *args], capture_output=True, text=True, timeout=timeout)
    if check and r.returncode != 0:
        raise Failed(f"`podman {' '.join(args)}` exited {r.returncode}: {(r.stdout + r.stderr)[-1500:]}")
    return r


def apt_mirror() -> str:
    """The Debian mirror this machine's apt uses (deb822 or one-line sources)."""
    for f in sorted(Path("/etc/apt/sources.list.d").glob("*.sources")):
        for block in f.read_text().split("\n\n"):
            fields = dict(re.findall(r"^(\w[\w-]*):\s*(.+)$", block, re.M))
            if re.search(r"\bbookworm\b", fields.get("Suites", "")) and "URIs" in fields:
                return fields["URIs"].split()[0]
    for f in [Path("/etc/apt/sources.list"), *Path("/etc/apt/sources.list.d").glob("*.list")]:
        if f.is_file():
            m = re.search(r"^deb\s+(?:\[[^]]*\]\s+)?(\S+)\s+bookworm\s", f.read_text(), re.M)
            if m:
                return m.group(1)
    raise Missing("no Debian bookworm mirror in /etc/apt/sources.list(.d)")


# What Debian's own slim images add, so that `apt-get install` in an image leaves no
# package files behind and no documentation is unpacked.
APT_CLEAN = """\
DPkg::Post-Invoke { "rm -f /var/cache/apt/archives/*.deb /var/cache/apt/archives/partial/*.deb /var/cache/apt/*.bin || true"; };
APT::Update::Post-Invoke { "rm -f /var/cache/apt/archives/*.deb /var/cache/apt/archives/partial/*.deb /var/cache/apt/*.bin || true"; };
Dir::Cache::pkgcache "";
Dir::Cache::srcpkgcache "";
"""
DPKG_SLIM = """\
path-exclude /usr/share/doc/*
path-include /usr/share/doc/*/copyright
path-exclude /usr/share/man/*
path-exclude /usr/share/info/*
path-exclude /usr/share/locale/*
"""


def slim(root: Path) -> None:
    """Makes a debootstrapped tree what a slim base image is: no package cache, no apt
    lists, no docs (copyrights kept), and the same for whatever is installed later."""
    (root / "etc/apt/apt.conf.d/docker-clean").write_text(APT_CLEAN)
    (root / "etc/dpkg/dpkg.cfg.d/docker-slim").write_text(DPKG_SLIM)
    for pattern in ("var/cache/apt/archives/*.deb", "var/cache/apt/*.bin", "var/lib/apt/lists/*"):
        for p in root.glob(pattern):
            if p.is_file():
                p.unlink()
    for d in ("usr/share/man", "usr/share/info", "usr/share/locale"):
        shutil.rmtree(root / d, ignore_errors=True)
    for d in (root / "usr/share/doc").glob("*"):
        for f in d.rglob("*"):
            if f.is_file() and f.name != "copyright":
                f.unlink()


def ensure_base_image() -> None:
    if podman("image", "exists", BASE_IMAGE, check=False).returncode == 0:
        log(f"ok    base image {BASE_IMAGE} present")
        return
    if not shutil.which("debootstrap"):
        raise Missing("debootstrap not found (Debian: apt-get install debootstrap)")
    mirror = apt_mirror()
    root = Path(tempfile.mkdtemp(prefix="homcull-rootfs-"))
    try:
        t = time.monotonic()
        r = subprocess.run(["debootstrap", "--variant=minbase", "bookworm", str(root), mirror],
                           capture_output=True, text=True, timeout=400)
        expect(r.returncode == 0, f"debootstrap failed: {(r.stdout + r.stderr)[-1500:]}")
        slim(root)
        tar = subprocess.Popen(["tar", "-C", str(root), "-c", "."], stdout=subprocess.PIPE)
        imp = subprocess.run(["podman", "import", "-", BASE_IMAGE], stdin=tar.stdout,
                             capture_output=True, text=True, timeout=300)
        tar.wait()
        expect(imp.returncode == 0 and tar.returncode == 0, f"podman import failed: {imp.stderr[-1000:]}")
        log(f"ok    base image {BASE_IMAGE} bootstrapped from Debian and imported in "
            f"{time.monotonic() - t:.0f} s")
    finally:
        shutil.rmtree(root, ignore_errors=True)


def build_image(bin_path: str) -> int:
    """Builds the runtime image around `bin_path`; returns its size in bytes."""
    ctx = Path(tempfile.mkdtemp(prefix="homcull-image-ctx-"))
    try:
        exe = ctx / "homcull"
        shutil.copy2(bin_path, exe)
        if shutil.which("strip"):
            subprocess.run(["strip", "--strip-debug", str(exe)], check=True, timeout=120)
        t = time.monotonic()
        podman("build", "--format", "docker", "--network", "host", "-f", str(REPO / "deploy" / "Dockerfile"),
               "--target", "runtime", "--build-arg", "BINARY_FROM=prebuilt", "-t", IMAGE, str(ctx),
               timeout=400)
        size = int(podman("image", "inspect", "--format", "{{.Size}}", IMAGE).stdout.strip())
        log(f"ok    built {IMAGE} (deploy/Dockerfile, target runtime, the host's binary) in "
            f"{time.monotonic() - t:.0f} s: image size {size / 1e6:.0f} MB (binary {exe.stat().st_size / 1e6:.0f} MB)")
        return size
    finally:
        shutil.rmtree(ctx, ignore_errors=True)


def wait_ready(base: str, what: str, timeout: float = 60) -> dict:
    seen = {}

    def ready():
        try:
            st, body = dr.get_json(f"{base}/readyz", timeout=3)
        except OSError:
            return False
        seen["body"] = body
        return st == 200

    dr.wait_for(ready, timeout, f"{what} to be ready")
    return seen["body"]


def host_server(bin_path: str, port: int, data: Path, procs: dr.Procs) -> str:
    env = {k: v for k, v in os.environ.items() if not k.startswith("HOMCULL_")}
    env["XDG_RUNTIME_DIR"] = str(data)
    procs.start("host", [bin_path, "serve", "--addr", f"127.0.0.1:{port}", "--data-dir", str(data),
                         "--backend", "cpu"], env)
    base = f"http://127.0.0.1:{port}"
    wait_ready(base, "the host binary")
    return base


def poses() -> list[dict]:
    return [dr.yaw_pose(p, yaw) for p, yaw in (((-60.0, 1.7, 0.0), -1.5707964), ((0.0, 1.7, 3.0), 0.3),
                                               ((-35.0, 1.7, -30.0), 1.2), ((10.0, 1.7, 10.0), 2.5))]


def answers(base: str, sid: str) -> list:
    st, res = dr.post_json(f"{base}/v1/scenes/{sid}/cull/batch", {"poses": poses()})
    expect(st == 200, f"cull/batch on {base} answered {st}: {res}")
    keep = ("objects", "candidates", "culled_by_frustum", "culled_by_occlusion", "occluders_used",
            "occluder_triangles")
    return [(r["visible"], {k: r["stats"][k] for k in keep}) for r in res["results"]]


class Deployment:
    """A running homcull container and how its operator stops and starts it."""

    def __init__(self, what: str, name: str, port: int, stop: list[list[str]], start: list[list[str]]):
        self.what, self.name, self.port = what, name, port
        self.base = f"http://127.0.0.1:{port}"
        self._stop, self._start = stop, start

    def stop(self) -> None:
        run_all(self._stop)

    def start(self) -> None:
        run_all(self._start)


def run_all(commands: list[list[str]]) -> None:
    for c in commands:
        r = subprocess.run(c, capture_output=True, text=True, timeout=90)
        if r.returncode != 0:
            raise Failed(f"`{' '.join(c)}` exited {r.returncode}: {(r.stdout + r.stderr)[-1500:]}")


def stop_during_stream(d: Deployment, grace: float) -> None:
    """Stops `d` while a WebSocket streams: close frame 1001, exit 0 within grace."""
    ws = dr.WebSocket(d.port, "/v1/scenes/demo/stream", timeout=15)
    try:
        expect(dr.recv_frame(ws)["kind"] == dr.HELLO, "first frame is not hello")
        dr.send_pose(ws, 1, poses()[0], want_full=True)
        expect(dr.recv_answer(ws, 1)["kind"] == dr.FULL, "first answer is not a full frame")
        t = time.monotonic()
        failure: list[BaseException] = []

        def stop():
            try:
                d.stop()
            except BaseException as e:  # noqa: BLE001  (reported below)
                failure.append(e)

        stopper = threading.Thread(target=stop)
        stopper.start()
        ws.sock.settimeout(grace + dr.GRACE_MARGIN_S)
        code = None
        try:
            while True:
                dr.recv_frame(ws)
        except dr.WsClosed as e:
            code = e.code
        except socket.timeout:
            raise Failed(f"no WebSocket close frame after stopping the {d.what}") from None
        stopper.join()
        if failure:
            raise failure[0]
        took = time.monotonic() - t
        expect(code == 1001, f"WebSocket closed with {code}, expected 1001")
        rc = podman("inspect", "--format", "{{.State.ExitCode}}", d.name).stdout.strip()
        expect(rc == "0", f"the {d.what} exited {rc} after SIGTERM, expected 0")
        expect(took <= grace + dr.GRACE_MARGIN_S, f"stopping took {took:.1f} s (grace {grace:g} s)")
        log(f"ok    stopped (SIGTERM) with a stream open: close frame 1001, exit 0 in {took:.2f} s "
            f"(grace {grace:g} s)")
    finally:
        ws.close()


def operator_checks(d: Deployment, host: str) -> None:
    """What an operator expects of a running homcull container, `host` being the host
    binary's server to compare answers with."""
    t = time.monotonic()
    ready = wait_ready(d.base, f"the {d.what}")
    expect(ready.get("backend") == "cpu" and ready.get("cpu_fallback") is False,
           f"without a GPU the container should cull on the native CPU backend: {ready}")
    log(f"ok    {d.what} ready in {time.monotonic() - t:.1f} s; /readyz: backend {ready['backend']}, "
        f"adapter {ready['adapter']!r}")

    pid = podman("inspect", "--format", "{{.State.Pid}}", d.name).stdout.strip()
    uid = re.search(r"^Uid:\s+(\d+)", Path(f"/proc/{pid}/status").read_text(), re.M)
    expect(uid is not None and uid.group(1) == "10001", f"the server runs as uid {uid and uid.group(1)}")
    ro = podman("exec", d.name, "sh", "-c", "touch /probe", check=False)
    expect(ro.returncode != 0, "the root file system is writable")
    podman("exec", d.name, "sh", "-c", "touch /data/.probe && rm /data/.probe")
    hc = podman("healthcheck", "run", d.name, check=False)
    expect(hc.returncode == 0, f"the HEALTHCHECK failed: {hc.stdout}{hc.stderr}")
    log("ok    runs as uid 10001, root read-only, /data writable, HEALTHCHECK passes")

    inside, outside = answers(d.base, "demo"), answers(host, "demo")
    expect(inside == outside, f"the {d.what} and the host binary answer the same culls differently")
    expect(any(v for v, _ in inside), "every pose sees nothing: the comparison would be vacuous")
    log(f"ok    {len(inside)} culls of the demo: the {d.what} answers exactly as the host binary "
        f"(visible {[len(v) for v, _ in inside]})")

    st, _, glb = dr.http("GET", f"{d.base}/v1/scenes/demo/glb")
    expect(st == 200, f"GET /v1/scenes/demo/glb answered {st}")
    st, _, body = dr.http("POST", f"{d.base}/v1/scenes?name=container-test", glb, "model/gltf-binary",
                          timeout=120)
    expect(st == 201, f"upload answered {st}: {body[:300]!r}")
    sid = json.loads(body)["id"]
    log(f"ok    uploaded the demo's GLB ({len(glb)} B) as scene {sid}")

    stop_during_stream(d, 10.0)
    d.start()
    wait_ready(d.base, f"the restarted {d.what}")
    st, lst = dr.get_json(f"{d.base}/v1/scenes")
    expect(st == 200 and any(s["id"] == sid for s in lst["scenes"]),
           f"scene {sid} did not survive the restart: {lst}")
    expect(answers(d.base, sid) == answers(d.base, "demo"), "the uploaded copy culls unlike the demo")
    log(f"ok    after a restart on the same volume scene {sid} is back and culls as the demo does")


def compose_file_for_podman_compose(dest: Path) -> Path:
    """deploy/compose.yaml as Debian's podman-compose (1.0.3) can read it: it predates
    `env_file`'s long syntax (`path`, `required: false`), so that entry is dropped when
    its file does not exist (which is what `required: false` means) and shortened when
    it does; and the image is used as built (no `build`)."""
    import yaml  # pyyaml: CI installs it for the deployment linters

    compose = yaml.safe_load((REPO / "deploy" / "compose.yaml").read_text())
    for svc in compose["services"].values():
        svc.pop("build", None)
        files = []
        for e in svc.pop("env_file", []) or []:
            path = e["path"] if isinstance(e, dict) else e
            if (REPO / "deploy" / path).is_file():
                files.append(str(REPO / "deploy" / path))
            elif not (isinstance(e, dict) and e.get("required") is False):
                raise Failed(f"compose.yaml's env_file {path} is required but missing")
        if files:
            svc["env_file"] = files
    out = dest / "compose.yaml"
    out.write_text(yaml.safe_dump(compose, sort_keys=False))
    return out


NGINX_IMAGE = "localhost/homcull-nginx:ci"
NGINX_CONTAINERFILE = """\
FROM localhost/debian:bookworm-slim
# hadolint ignore=DL3008
RUN apt-get update && apt-get install -y --no-install-recommends nginx-light \\
    && rm -rf /var/lib/apt/lists/*
"""


class ContainerLauncher(dr.ProcessLauncher):
    """`scale_out`'s replicas and nginx as containers on one shared named volume, on
    the host's network (so that nginx's upstreams stay 127.0.0.1:PORT as in the
    template). Each is started attached (`podman run --rm`, its client the process the
    check watches); a replica is killed with `podman kill -s KILL`."""

    what = "containers"

    def __init__(self, prefix: str):
        super().__init__("")
        self.prefix = prefix
        self.volume = f"{prefix}-data"
        self.names: list[str] = []

    def nginx_binary(self) -> str:
        if podman("image", "exists", NGINX_IMAGE, check=False).returncode != 0:
            ctx = Path(tempfile.mkdtemp(prefix="homcull-nginx-ctx-"))
            try:
                (ctx / "Containerfile").write_text(NGINX_CONTAINERFILE)
                podman("build", "--network", "host", "-t", NGINX_IMAGE, str(ctx), timeout=300)
            finally:
                shutil.rmtree(ctx, ignore_errors=True)
        return "nginx"

    def shared_data(self, work: Path) -> str:
        podman("volume", "create", self.volume)
        return f"volume {self.volume}"

    def _run(self, name: str) -> list[str]:
        cname = f"{self.prefix}-{name}"
        self.names.append(cname)
        return ["podman", "run", "--rm", "--name", cname, "--network", "host"]

    def replica(self, name: str, port: int, shared: str, args: list[str]) -> list[str]:
        return [*self._run(name), "--read-only", "--tmpfs", "/tmp:mode=1777", "-v", f"{self.volume}:/data",
                "--cap-drop", "ALL", "--security-opt", "no-new-privileges",
                "-e", f"HOMCULL_ADDR=127.0.0.1:{port}", IMAGE, "serve", *args]

    def nginx(self, nginx: str, prefix: Path, conf: Path) -> list[str]:
        return [*self._run("nginx"), "-v", f"{prefix}:{prefix}", NGINX_IMAGE,
                nginx, "-p", str(prefix), "-e", str(prefix / "error.log"), "-c", str(conf)]

    def kill(self, name: str, proc: subprocess.Popen) -> None:
        podman("kill", "-s", "KILL", f"{self.prefix}-{name}")

    def cleanup(self) -> None:
        for n in self.names:
            podman("rm", "-f", "-t", "0", n, check=False)
        podman("volume", "rm", "-f", self.volume, check=False)


def run_in_container(bin_path: str) -> None:
    ensure_base_image()
    build_image(bin_path)
    inspect = json.loads(podman("image", "inspect", IMAGE).stdout)[0]
    expect(inspect.get("Healthcheck") or inspect["Config"].get("Healthcheck"), "the image carries no HEALTHCHECK")
    tools = podman("run", "--rm", "--entrypoint", "sh", IMAGE, "-c",
                   "for t in cc gcc rustc cargo ld make; do command -v $t; done; true").stdout.split()
    expect(not tools, f"build tools in the runtime image: {tools}")
    log("ok    no build tools in the runtime image (cc, gcc, rustc, cargo, ld, make)")

    tag = f"homcull-test-{os.getpid()}"
    tmp = Path(tempfile.mkdtemp(prefix="homcull-container-"))
    procs = dr.Procs(tmp / "logs")
    (tmp / "logs").mkdir()
    (tmp / "host-data").mkdir()
    running: list[str] = []
    names: list[str] = []
    compose: list[str] | None = None
    try:
        host = host_server(bin_path, dr.free_port(), tmp / "host-data", procs)

        log("== podman run, as compose.yaml runs it")
        port = dr.free_port()
        podman("volume", "create", tag)
        running.append(tag)
        podman("run", "-d", "--name", tag, "--read-only", "--tmpfs", "/tmp:mode=1777", "-v", f"{tag}:/data",
               "--cap-drop", "ALL", "--security-opt", "no-new-privileges", "-e", "HOMCULL_SHUTDOWN_GRACE_S=10",
               "-p", f"127.0.0.1:{port}:8080", IMAGE)
        operator_checks(Deployment("container", tag, port, [["podman", "stop", "-t", "30", tag]],
                                   [["podman", "start", tag]]), host)
        podman("rm", "-f", "-t", "0", tag)

        if not shutil.which("podman-compose"):
            raise Missing("podman-compose not found (Debian: apt-get install podman-compose)")
        log("== podman-compose up with deploy/compose.yaml")
        port = dr.free_port()
        project = f"homcull-compose-{os.getpid()}"
        file = compose_file_for_podman_compose(tmp)
        compose = ["podman-compose", "-p", project, "-f", str(file)]
        os.environ["HOMCULL_PUBLISH"] = f"127.0.0.1:{port}"
        podman("tag", IMAGE, "localhost/homcull:latest")  # compose.yaml's `image`
        run_all([[*compose, "up", "-d"]])
        names = podman("ps", "-a", "--filter", f"label=io.podman.compose.project={project}",
                       "--format", "{{.Names}}").stdout.split()
        expect(len(names) == 1, f"compose started {names}, expected one container")
        operator_checks(Deployment("compose service", names[0], port, [[*compose, "stop"]],
                                   [[*compose, "start"]]), host)

        log("== scale-out: three replicas and nginx as containers on one volume")
        dr.scale_out(bin_path, ContainerLauncher(f"homcull-scale-{os.getpid()}"))
    except BaseException:
        for name in running + names:
            logs = podman("logs", name, check=False)
            log(f"{name} log (tail):\n{(logs.stdout + logs.stderr)[-3000:]}")
        procs.dump_logs()
        raise
    finally:
        procs.stop_all()
        podman("rm", "-f", "-t", "0", tag, check=False)
        podman("volume", "rm", "-f", tag, check=False)
        if compose:
            subprocess.run([*compose, "down", "-v"], capture_output=True, timeout=90)
            for kind in ("volume", "network"):  # podman-compose 1.0.3's down leaves them
                for v in podman(kind, "ls", "--format", "{{.Name}}", check=False).stdout.split():
                    if v.startswith(compose[2]):
                        podman(kind, "rm", "-f", v, check=False)
        shutil.rmtree(tmp, ignore_errors=True)


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default=str(REPO / "target" / "release" / "homcull"), help="the homcull binary")
    args = ap.parse_args()
    bin_path = str(Path(args.bin).resolve())
    if not shutil.which("podman"):
        log("MISSING podman (Debian: apt-get install podman runc debootstrap)")
        return 2
    conf = Path(tempfile.mkdtemp(prefix="homcull-podman-")) / "containers.conf"
    conf.write_text(CONTAINERS_CONF)
    os.environ["CONTAINERS_CONF"] = str(conf)

    def alarm(*_):
        raise Failed(f"the check took longer than {TIME_LIMIT_S:.0f} s")

    signal.signal(signal.SIGALRM, alarm)
    signal.alarm(int(TIME_LIMIT_S))
    t = time.monotonic()
    try:
        run_in_container(bin_path)
    except Missing as e:
        log(f"MISSING {e}")
        return 2
    except Exception:  # noqa: BLE001
        log(f"FAIL  after {time.monotonic() - t:.1f} s:\n{traceback.format_exc()}")
        return 1
    finally:
        signal.alarm(0)
        shutil.rmtree(conf.parent, ignore_errors=True)
    log(f"container_runtime: passed in {time.monotonic() - t:.1f} s")
    return 0


if __name__ == "__main__":
    sys.exit(main())
