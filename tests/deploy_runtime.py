#!/usr/bin/env python3
"""Runtime checks of homcull's deployment, with the release binary and no
container engine:

run_as_image(bin)
    Runs the binary the way deploy/Dockerfile's runtime stage would: its ENV, its
    ENTRYPOINT + CMD (resolved through PATH, as Docker does), its USER, its WORKDIR,
    HOMCULL_ADDR and the data dir remapped as below, on a read-only root file system
    except the data dir and a private /tmp. Then: `homcull healthcheck` (the HEALTHCHECK
    command, same env and user) exits 0, /healthz is 200, /readyz is 200 and names the
    adapter, an open WebSocket stream gets a close frame with code 1001 when the
    STOPSIGNAL (SIGTERM) arrives, and the process exits 0 within HOMCULL_SHUTDOWN_GRACE_S
    plus a small margin. Nothing is written outside the data dir and the private /tmp.

scale_out(bin)
    Three `homcull serve --addr 127.0.0.1:<p_i> --data-dir <shared> --rescan-s 1` share
    one data dir behind nginx, configured from deploy/nginx/nginx.conf.template. A GLB
    uploaded through nginx shows up on every replica; the same cull answers identically
    on all three; a WebSocket stream through nginx survives the SIGKILL of the replica
    serving it: the client sees the connection close, reconnects through nginx (to
    another replica), asks for a full frame and gets the same visible set as a REST cull.

Remapping (what differs from a real container, and why):
  * HOMCULL_ADDR 0.0.0.0:8080  -> 127.0.0.1:<free port> (loopback only, no fixed port).
  * HOMCULL_DATA_DIR /data (also VOLUME and WORKDIR) -> <tmp root>/data, owned by the
    image's USER with mode 0750, as the image creates /data.
  * /tmp (a tmpfs in compose / Kubernetes: `--tmpfs /tmp`, an emptyDir) -> <tmp root>/tmp,
    mode 1777; so XDG_CACHE_HOME=/tmp/.cache becomes <tmp root>/tmp/.cache. Any other ENV
    value under /data or /tmp is remapped the same way.
  * /usr/local/bin/homcull -> <tmp root>/usr/local/bin/homcull (a copy of --bin), first on
    PATH, so ENTRYPOINT ["homcull"] resolves as it does in the image.
  * HOME=/nonexistent (the home useradd gives the image's user; Docker sets HOME from it).
  * Added for this machine, not in the image: WGPU_BACKEND=vulkan (unless set) and
    XDG_RUNTIME_DIR=<tmp root>/tmp; VK_*, MESA_*, LP_*, WGPU_* and RUST_LOG pass through.
  * USER 10001:10001 -> the same IDs through `setpriv --reuid --regid --clear-groups`
    when this runs as root; otherwise the current (non-root) user.
  * Read-only root: as root, the server runs in a private mount namespace (`unshare -m`)
    where / is remounted read-only and only the data dir and the private /tmp are
    writable, like `docker run --read-only --tmpfs /tmp -v ...:/data`. Without root (or
    without unshare) the check falls back to comparing snapshots of the tree around the
    data dir and of the repository's top level before and after the run, and says so.

The WebSocket client is this file's own (RFC 6455 over a socket, standard library only),
and so is its codec of the binary frames; before any check runs, the codec is tested
against proto/tests/golden/. It understands wire versions 1 to 4 and speaks the version
of the server's Hello.

Usage: python3 tests/deploy_runtime.py [--bin PATH] [--only run_as_image|scale_out]
Exit status: 0 passed; 1 failed; 2 a prerequisite is missing (nginx, setpriv, ...).
Everything listens on 127.0.0.1 only; each check is bounded (90 s) and every process it
starts is killed in a `finally`.
"""

from __future__ import annotations

import argparse
import base64
import hashlib
import json
import os
import re
import shutil
import signal
import socket
import struct
import subprocess
import sys
import tempfile
import time
import traceback
import urllib.error
import urllib.request
from pathlib import Path

sys.path.insert(0, str(Path(__file__).resolve().parent))
import deploy_check as dc  # noqa: E402  (the Dockerfile / nginx / clap-help parsers)

REPO = dc.REPO
DOCKERFILE = dc.DOCKERFILE
NGINX_TEMPLATE = dc.NGINX_TEMPLATE
SHARED_GLB = REPO.parent / "shared" / "scenes" / "etoile.glb"

TIME_LIMIT_S = 90.0  # per check
GRACE_MARGIN_S = 3.0  # SIGTERM -> exit may take this much longer than the grace period
DEFAULT_PATH = "/usr/local/sbin:/usr/local/bin:/usr/sbin:/usr/bin:/sbin:/bin"  # Docker's
PASS_THROUGH = ("VK_", "MESA_", "LP_", "WGPU_", "RUST_LOG", "RUST_BACKTRACE")


class Failed(Exception):
    pass


class Missing(Exception):
    """A prerequisite is missing: exit 2 (the Rust test skips unless CI is set)."""


def log(msg: str) -> None:
    print(msg, flush=True)


def expect(cond: bool, msg: str) -> None:
    if not cond:
        raise Failed(msg)


class Deadline:
    def __init__(self, seconds: float, what: str):
        self.end = time.monotonic() + seconds
        self.what = what

    def left(self) -> float:
        return self.end - time.monotonic()

    def check(self, doing: str) -> None:
        if self.left() <= 0:
            raise Failed(f"{self.what}: over its time limit while {doing}")


def wait_for(pred, timeout: float, what: str, every: float = 0.1):
    end = time.monotonic() + timeout
    last_err = None
    while True:
        try:
            v = pred()
            if v:
                return v
        except Exception as e:  # noqa: BLE001 - keep polling, report the last error
            last_err = e
        if time.monotonic() >= end:
            raise Failed(f"timed out after {timeout:.0f} s waiting for {what}"
                         + (f" (last error: {last_err})" if last_err else ""))
        time.sleep(every)


def free_port() -> int:
    with socket.socket() as s:
        s.bind(("127.0.0.1", 0))
        return s.getsockname()[1]


def port_free(port: int) -> bool:
    with socket.socket() as s:
        s.setsockopt(socket.SOL_SOCKET, socket.SO_REUSEADDR, 1)  # as the servers bind
        try:
            s.bind(("127.0.0.1", port))
            return True
        except OSError:
            return False


# --------------------------------------------------------------------------- HTTP


def http(method: str, url: str, body: bytes | None = None, ctype: str | None = None,
         timeout: float = 30.0) -> tuple[int, dict, bytes]:
    assert url.startswith("http://127.0.0.1:"), url  # loopback only
    req = urllib.request.Request(url, data=body, method=method)
    if ctype:
        req.add_header("Content-Type", ctype)
    try:
        with urllib.request.urlopen(req, timeout=timeout) as r:
            return r.status, dict(r.headers), r.read()
    except urllib.error.HTTPError as e:
        return e.code, dict(e.headers), e.read()


def get_json(url: str, timeout: float = 10.0) -> tuple[int, object]:
    st, _, body = http("GET", url, timeout=timeout)
    try:
        return st, json.loads(body)
    except ValueError:
        return st, body.decode("utf-8", "replace")


def post_json(url: str, obj, timeout: float = 60.0) -> tuple[int, object]:
    st, _, body = http("POST", url, json.dumps(obj).encode(), "application/json", timeout)
    try:
        return st, json.loads(body)
    except ValueError:
        return st, body.decode("utf-8", "replace")


def metric(base: str, name: str) -> float:
    """A gauge/counter without labels from /metrics (0 if absent)."""
    st, _, body = http("GET", f"{base}/metrics", timeout=5)
    expect(st == 200, f"{base}/metrics answered {st}")
    for line in body.decode().splitlines():
        parts = line.split()
        if len(parts) == 2 and parts[0] == name:
            return float(parts[1])
    return 0.0


# --------------------------------------------------------------------------- WebSocket (RFC 6455)

WS_GUID = "258EAFA5-E914-47DA-95CA-C5AB0DC85B11"


class WsClosed(Exception):
    """The peer closed: `code` is the close frame's status (None: no close frame, EOF/RST)."""

    def __init__(self, code: int | None, reason: str):
        super().__init__(f"WebSocket closed: code {code}, reason {reason!r}")
        self.code, self.reason = code, reason


class WebSocket:
    """A minimal client: handshake, masked frames out, fragments, ping/pong and close."""

    def __init__(self, port: int, path: str, timeout: float = 10.0):
        self.sock = socket.create_connection(("127.0.0.1", port), timeout=timeout)
        self.sock.settimeout(timeout)
        self.buf = b""
        self.closed = False
        self.version: int | None = None  # wire protocol version, from the server's Hello
        key = base64.b64encode(os.urandom(16)).decode()
        self.sock.sendall((f"GET {path} HTTP/1.1\r\nHost: 127.0.0.1:{port}\r\n"
                           "Upgrade: websocket\r\nConnection: Upgrade\r\n"
                           f"Sec-WebSocket-Key: {key}\r\nSec-WebSocket-Version: 13\r\n\r\n").encode())
        while b"\r\n\r\n" not in self.buf:
            chunk = self.sock.recv(4096)
            if not chunk:
                raise Failed(f"WebSocket handshake on :{port}{path}: connection closed")
            self.buf += chunk
        head, self.buf = self.buf.split(b"\r\n\r\n", 1)
        lines = head.decode("latin-1").split("\r\n")
        status = lines[0].split()
        if len(status) < 2 or status[1] != "101":
            raise Failed(f"WebSocket handshake on :{port}{path} answered {lines[0]!r}")
        headers = {k.strip().lower(): v.strip() for k, v in (ln.split(":", 1) for ln in lines[1:] if ":" in ln)}
        want = base64.b64encode(hashlib.sha1((key + WS_GUID).encode()).digest()).decode()
        expect(headers.get("sec-websocket-accept") == want, "bad Sec-WebSocket-Accept")

    def _send(self, opcode: int, payload: bytes) -> None:
        n = len(payload)
        head = bytes([0x80 | opcode])
        if n < 126:
            head += bytes([0x80 | n])
        elif n < 1 << 16:
            head += bytes([0x80 | 126]) + struct.pack(">H", n)
        else:
            head += bytes([0x80 | 127]) + struct.pack(">Q", n)
        mask = os.urandom(4)
        masked = bytes(b ^ mask[i & 3] for i, b in enumerate(payload))
        self.sock.sendall(head + mask + masked)

    def send_binary(self, payload: bytes) -> None:
        self._send(0x2, payload)

    def _read(self, n: int) -> bytes:
        while len(self.buf) < n:
            try:
                chunk = self.sock.recv(65536)
            except ConnectionResetError:
                chunk = b""
            if not chunk:
                self.closed = True
                raise WsClosed(None, "connection closed without a close frame")
            self.buf += chunk
        out, self.buf = self.buf[:n], self.buf[n:]
        return out

    def _frame(self) -> tuple[bool, int, bytes]:
        b0, b1 = self._read(2)
        n = b1 & 0x7F
        if n == 126:
            n = struct.unpack(">H", self._read(2))[0]
        elif n == 127:
            n = struct.unpack(">Q", self._read(8))[0]
        mask = self._read(4) if b1 & 0x80 else None
        data = self._read(n)
        if mask:
            data = bytes(b ^ mask[i & 3] for i, b in enumerate(data))
        return bool(b0 & 0x80), b0 & 0x0F, data

    def recv(self) -> bytes:
        """The next data message (binary or text bytes); raises WsClosed on close."""
        parts: list[bytes] = []
        while True:
            fin, op, data = self._frame()
            if op == 0x8:  # close: answer it, then report it
                code = struct.unpack(">H", data[:2])[0] if len(data) >= 2 else None
                reason = data[2:].decode("utf-8", "replace")
                try:
                    self._send(0x8, data[:2])
                except OSError:
                    pass
                self.closed = True
                raise WsClosed(code, reason)
            if op == 0x9:
                self._send(0xA, data)
                continue
            if op == 0xA:
                continue
            parts.append(data)
            if fin:
                return b"".join(parts)

    def close(self) -> None:
        try:
            if not self.closed:
                self._send(0x8, struct.pack(">H", 1000))
        except OSError:
            pass
        try:
            self.sock.close()
        except OSError:
            pass


# --------------------------------------------------------------------------- binary frames
# Layout: proto/src/frame/ (module docs); vectors: proto/tests/golden/. Three wire versions
# are understood: 1 (6-word header with kind and payload_words words, 8 stats words, two
# delta count words), 2 (4-word header with `version | kind << 16`, 5 stats words, one
# delta count word `added | removed << 16`) and 3 (version 2 plus frames with levels of
# detail, kinds 6 and 7, and stereo poses, pose flag bit 1 and two more words) and 4
# (version 3 with a sixth stats word, the scene version, and a writer's frames, kinds 8
# transforms and 9 applied). The low
# 16 bits of word 1 are the version in all; a client speaks the version of the server's
# Hello. `check_codec` tests this codec against the golden vectors before anything else
# runs.

MAGIC = 0x4C434D48
VERSIONS = (1, 2, 3, 4, 5)
HELLO, POSE, FULL, DELTA, ERROR, FULL_LOD, DELTA_LOD, TRANSFORMS, APPLIED, REGION = range(1, 11)
KIND_NAMES = {HELLO: "hello", POSE: "pose", FULL: "full", DELTA: "delta", ERROR: "error",
              FULL_LOD: "full_lod", DELTA_LOD: "delta_lod", TRANSFORMS: "transforms",
              APPLIED: "applied", REGION: "region"}
STATS = {
    1: ("objects", "candidates", "culled_by_frustum", "culled_by_occlusion", "occluders_used",
        "dropped_poses", "gpu_us", "total_us"),
    2: ("candidates", "occluders_used", "dropped_poses", "gpu_us", "total_us"),
    3: ("candidates", "occluders_used", "dropped_poses", "gpu_us", "total_us"),
    4: ("candidates", "occluders_used", "dropped_poses", "gpu_us", "total_us", "scene_version"),
    5: ("candidates", "occluders_used", "dropped_poses", "gpu_us", "total_us", "scene_version"),
}
GOLDEN = REPO / "proto" / "tests" / "golden"


def f32(x: float) -> float:
    return struct.unpack("<f", struct.pack("<f", x))[0]


def header(version: int, kind: int, seq: int, ack: int, payload_words: int) -> bytes:
    if version == 1:
        return struct.pack("<6I", MAGIC, 1, kind, seq, ack, payload_words)
    return struct.pack("<4I", MAGIC, version | kind << 16, seq, ack)


def pose_frame(seq: int, pose: dict, want_full: bool = False, version: int = 1) -> bytes:
    stereo = pose.get("stereo")
    flags = (1 if want_full else 0) | (2 if stereo else 0)
    payload = struct.pack("<I3f4ff2I2f", flags, *pose["position"], *pose["rotation"],
                          pose["fov_y_deg"], *pose["viewport"], pose["near"], pose["far"])
    if stereo:
        payload += struct.pack("<2f", stereo["ipd_m"], stereo.get("convergence_m", 0.0))
    return header(version, POSE, seq, 0, len(payload) // 4) + payload


def decode_frame(b: bytes) -> dict:
    expect(len(b) >= 16 and len(b) % 4 == 0, f"frame of {len(b)} bytes")
    magic, w1 = struct.unpack_from("<2I", b)
    version = w1 & 0xFFFF
    expect(magic == MAGIC, f"bad magic {magic:#x}")
    expect(version in VERSIONS, f"wire protocol version {version}: tests/deploy_runtime.py speaks "
                                f"{VERSIONS}; teach its codec the new layout (proto/src/frame/)")
    if version == 1:
        expect(len(b) >= 24, f"v1 frame of {len(b)} bytes")
        _, _, kind, seq, ack, words = struct.unpack_from("<6I", b)
        expect(words * 4 == len(b) - 24, "payload_words does not match the frame length")
        off = 24
    else:
        kind = w1 >> 16
        seq, ack = struct.unpack_from("<2I", b, 8)
        off = 16
    n = (len(b) - off) // 4
    w = struct.unpack_from(f"<{n}I", b, off)
    f = {"version": version, "kind": kind, "seq": seq, "ack": ack, "byte_length": len(b)}
    if kind in (HELLO, ERROR):
        key, text = ("object_count", "info_json") if kind == HELLO else ("code", "message")
        f[key], nbytes = w[0], w[1]
        f[text] = b[off + 8:off + 8 + nbytes].decode()
        expect(off + 8 + (nbytes + 3) // 4 * 4 == len(b), f"{KIND_NAMES[kind]} frame length mismatch")
        if kind == HELLO:
            f["info"] = json.loads(f["info_json"])
    elif kind in (FULL, DELTA, FULL_LOD, DELTA_LOD):
        names = STATS[version]
        f["stats"] = dict(zip(names, w[:len(names)]))
        c = len(names)

        def levels_at(words: int, count: int) -> list[int]:
            # `count` level bytes from payload word `words` on (one byte each, zero-padded).
            return list(b[off + 4 * words:off + 4 * words + count])

        if kind in (FULL, FULL_LOD):
            count = w[c]
            f["ids"] = list(w[c + 1:c + 1 + count])
            level_words = (count + 3) // 4 if kind == FULL_LOD else 0
            if kind == FULL_LOD:
                f["levels"] = levels_at(c + 1 + count, count)
            expect(c + 1 + count + level_words == n, "full frame length mismatch")
        else:
            if version == 1:
                na, nr, c = w[c], w[c + 1], c + 2
            else:
                na, nr, c = w[c] & 0xFFFF, w[c] >> 16, c + 1
            nc = 0
            if kind == DELTA_LOD:
                nc, c = w[c], c + 1
            f["added"], f["removed"] = list(w[c:c + na]), list(w[c + na:c + na + nr])
            level_words = 0
            if kind == DELTA_LOD:
                f["changed"] = list(w[c + na + nr:c + na + nr + nc])
                levels = levels_at(c + na + nr + nc, na + nc)
                f["added_levels"], f["changed_levels"] = levels[:na], levels[na:]
                level_words = (na + nc + 3) // 4
            expect(c + na + nr + nc + level_words == n, "delta frame length mismatch")
    elif kind == POSE:
        flags, *rest = struct.unpack_from("<I3f4ff2I2f", b, off)
        f.update(want_full=bool(flags & 1), position=rest[0:3], rotation=rest[3:7], fov_y_deg=rest[7],
                 viewport=rest[8:10], near=rest[10], far=rest[11])
        if flags & 2:
            ipd, convergence = struct.unpack_from("<2f", b, off + 13 * 4)
            f["stereo"] = {"ipd_m": ipd, **({"convergence_m": convergence} if convergence != 0 else {})}
    elif kind == TRANSFORMS:
        count = w[1]
        expect(2 + 20 * count == n, "transforms frame length mismatch")
        f["ids"] = [w[2 + 20 * k] for k in range(count)]
    elif kind == APPLIED:
        expect(n == 3, "applied frame length mismatch")
        f["version_made"], f["applied"] = w[0] | w[1] << 32, w[2]
    elif kind == REGION:
        expect(n == 8, "region frame length mismatch")
        cx, cy, cz, r, ax, ay, az, t = struct.unpack_from("<8f", b, off)
        f.update(centre=[cx, cy, cz], radius_m=r, axis=[ax, ay, az], turn_deg=t)
    else:
        raise Failed(f"unknown frame kind {kind}")
    return f


def check_codec() -> str:
    """This file's codec against proto/tests/golden/ (whatever version they are in)."""
    meta = json.loads((GOLDEN / "frames.json").read_text())
    version = meta.get("protocol_version", 1)
    for g in meta["frames"]:
        raw = bytes.fromhex("".join((GOLDEN / g["file"]).read_text().split()))
        where = f"golden {g['file']}"
        f = decode_frame(raw)
        expect(f["version"] == version, f"{where}: version {f['version']} != {version}")
        expect(KIND_NAMES.get(f["kind"]) == g["kind"], f"{where}: kind {f['kind']} != {g['kind']}")
        for k in ("seq", "ack", "byte_length", "object_count", "info_json", "code", "message", "ids",
                  "added", "removed", "levels", "changed", "added_levels", "changed_levels", "stereo"):
            if k in g:
                expect(f.get(k) == g[k], f"{where}: {k} {f.get(k)!r} != {g[k]!r}")
        for k, v in g.get("stats", {}).items():
            if k in f["stats"]:
                expect(f["stats"][k] == v, f"{where}: stats.{k} {f['stats'][k]} != {v}")
        if g["kind"] == "transforms":
            expect(f["ids"] == [o["id"] for o in g["objects"]], f"{where}: transforms ids {f['ids']}")
        if g["kind"] == "applied":
            expect((f["version_made"], f["applied"]) == (g["version"], g["applied"]), f"{where}: applied")
        if g["kind"] == "region":
            got = (f["centre"], f["radius_m"], f["axis"], f["turn_deg"])
            expect(got == (g["centre"], g["radius_m"], g["axis"], g["turn_deg"]), f"{where}: region {got}")
        if g["kind"] == "pose":
            enc = pose_frame(g["seq"], g, g["want_full"], version)
            expect(enc == raw, f"{where}: encoding the pose gives {enc.hex()}, expected {raw.hex()}")
    return f"codec agrees with {len(meta['frames'])} golden frames (protocol version {version})"


def apply(visible: list[int], frame: dict) -> list[int]:
    if frame["kind"] in (FULL, FULL_LOD):
        return frame["ids"]
    s = (set(visible) - set(frame["removed"])) | set(frame["added"])
    return sorted(s)


def recv_frame(ws: WebSocket) -> dict:
    f = decode_frame(ws.recv())
    if f["kind"] == HELLO:
        ws.version = f["version"]  # speak the server's version
        pv = f["info"].get("protocol_version")
        expect(pv in (None, f["version"]), f"hello: header version {f['version']}, JSON protocol_version {pv}")
    elif f["kind"] == ERROR:
        raise Failed(f"server sent an error frame: code {f['code']}: {f['message']}")
    else:
        expect(f["kind"] in (FULL, DELTA, FULL_LOD, DELTA_LOD), f"server sent a {KIND_NAMES.get(f['kind'])} frame")
        expect(f["version"] == ws.version, f"frame version {f['version']} != the hello's {ws.version}")
    return f


def send_pose(ws: WebSocket, seq: int, pose: dict, want_full: bool = False) -> None:
    expect(ws.version is not None, "sending a pose before the hello")
    ws.send_binary(pose_frame(seq, pose, want_full, ws.version))


def recv_answer(ws: WebSocket, seq: int) -> dict:
    """The Full/Delta frame that acks pose `seq` (earlier answers are skipped)."""
    while True:
        f = recv_frame(ws)
        if f["kind"] in (FULL, DELTA) and f["ack"] == seq:
            return f
        expect(f["kind"] in (FULL, DELTA) and f["ack"] < seq, f"unexpected frame {f}")


def yaw_pose(pos: tuple[float, float, float], yaw: float) -> dict:
    """A pose with f32-exact numbers (the binary frame and the JSON agree bit for bit)."""
    import math
    return {
        "position": [f32(v) for v in pos],
        "rotation": [0.0, f32(math.sin(yaw / 2)), 0.0, f32(math.cos(yaw / 2))],
        "fov_y_deg": 60.0, "viewport": [640, 360], "near": 0.25, "far": 2000.0,
    }


# --------------------------------------------------------------------------- processes


class Procs:
    """Every process a check starts; all killed in `stop_all` (called from a finally)."""

    def __init__(self, logdir: Path):
        self.logdir = logdir
        self.procs: list[tuple[str, subprocess.Popen, Path]] = []

    def start(self, name: str, cmd: list[str], env: dict, cwd: str | Path | None = None) -> subprocess.Popen:
        logf = self.logdir / f"{name}.log"
        with open(logf, "wb") as out:
            p = subprocess.Popen(cmd, env=env, cwd=cwd, stdin=subprocess.DEVNULL, stdout=out,
                                 stderr=subprocess.STDOUT, start_new_session=True)
        self.procs.append((name, p, logf))
        return p

    def log_tail(self, name: str, n: int = 40) -> str:
        for nm, _, logf in self.procs:
            if nm == name and logf.exists():
                return "\n".join(logf.read_text(errors="replace").splitlines()[-n:])
        return ""

    def dump_logs(self, n: int = 25) -> None:
        for name, p, logf in self.procs:
            if logf.exists():
                tail = "\n".join("    " + ln for ln in logf.read_text(errors="replace").splitlines()[-n:])
                log(f"  --- {name} (pid {p.pid}, exit {p.returncode}) log tail:\n{tail}")

    def stop_all(self) -> None:
        for name, p, _ in self.procs:
            if p.poll() is None:
                try:
                    os.killpg(p.pid, signal.SIGKILL)  # the session this check created for it
                except (ProcessLookupError, PermissionError):
                    try:
                        p.kill()
                    except ProcessLookupError:
                        pass
            try:
                p.wait(timeout=10)
            except subprocess.TimeoutExpired:
                log(f"  warning: {name} (pid {p.pid}) did not die")


def base_server_env() -> dict:
    env = dict(os.environ)
    env = {k: v for k, v in env.items() if not k.startswith("HOMCULL_")}
    env.setdefault("WGPU_BACKEND", "vulkan")
    env.setdefault("XDG_RUNTIME_DIR", "/tmp")
    env.setdefault("RUST_LOG", "homcull=info,wgpu=error")
    return env


def wait_ready(base: str, proc: subprocess.Popen, timeout: float, name: str) -> dict:
    def ready():
        if proc.poll() is not None:
            raise Failed(f"{name} exited with {proc.returncode} before it was ready")
        st, body = get_json(f"{base}/readyz", timeout=3)
        return body if st == 200 else None

    try:
        return wait_for(ready, timeout, f"{name} {base}/readyz to answer 200", every=0.1)
    except Failed as e:
        if proc.poll() is not None:
            raise Failed(f"{name} exited with {proc.returncode} before it was ready") from e
        raise


def find_nginx() -> str | None:
    return shutil.which("nginx") or next((p for p in ("/usr/sbin/nginx",) if os.access(p, os.X_OK)), None)


# --------------------------------------------------------------------------- run as the image


class Image:
    """What deploy/Dockerfile's final stage says about running the binary."""

    def __init__(self) -> None:
        stages = dc.parse_dockerfile(DOCKERFILE.read_text())
        final = stages[-1]
        self.env = final.env()

        def exec_form(cmd: str) -> list[str]:
            ins = final.last(cmd)
            expect(ins is not None, f"Dockerfile has no {cmd}")
            v = ins.exec_form()
            expect(v is not None, f"Dockerfile {cmd} is not exec form: {ins.rest}")
            return v

        self.entrypoint = exec_form("ENTRYPOINT")
        self.cmd = exec_form("CMD")
        hc = final.last("HEALTHCHECK")
        expect(hc is not None, "Dockerfile has no HEALTHCHECK")
        m = re.search(r"\bCMD\s+(\[.*\])\s*$", hc.rest)
        expect(m is not None, f"HEALTHCHECK is not `CMD [exec form]`: {hc.rest}")
        self.healthcheck = json.loads(m.group(1))
        user = final.last("USER")
        expect(user is not None, "Dockerfile has no USER")
        uid, _, gid = user.rest.strip().partition(":")
        expect(uid.isdigit() and (not gid or gid.isdigit()), f"USER {user.rest} is not numeric")
        self.uid, self.gid = int(uid), int(gid or uid)
        expect(self.uid != 0, "the image runs as root")
        wd = final.last("WORKDIR")
        self.workdir = wd.rest.strip() if wd else "/"
        sig = final.last("STOPSIGNAL")
        self.stopsignal = getattr(signal, sig.rest.strip()) if sig else signal.SIGTERM
        self.copied_bin = next((i.rest.split()[-1] for i in final.all("COPY")
                                if i.rest.split()[-1].endswith("/homcull")), "/usr/local/bin/homcull")
        self.volumes = [json.loads(v.rest)[0] if v.rest.startswith("[") else v.rest.split()[0]
                        for v in final.all("VOLUME")]


def path_remapper(root: Path, data: Path, tmp: Path):
    def remap(v: str) -> str:
        for src, dst in (("/data", data), ("/tmp", tmp)):
            if v == src or v.startswith(src + "/"):
                return str(dst) + v[len(src):]
        return v
    return remap


def snapshot(root: Path, skip: set[Path]) -> dict[str, tuple]:
    out = {}
    for dirpath, dirnames, filenames in os.walk(root):
        d = Path(dirpath)
        dirnames[:] = [n for n in dirnames if d / n not in skip]
        for n in filenames + dirnames:
            p = d / n
            try:
                st = p.lstat()
            except FileNotFoundError:
                continue
            out[str(p.relative_to(root))] = (st.st_mode, st.st_size, st.st_mtime_ns)
    return out


def listing(root: Path) -> list[str]:
    out = []
    for dirpath, dirnames, filenames in os.walk(root):
        for n in sorted(filenames):
            p = Path(dirpath) / n
            out.append(f"{p.relative_to(root)} ({p.stat().st_size} B)")
        dirnames.sort()
    return out


def run_as_image(bin_path: str) -> None:
    dl = Deadline(TIME_LIMIT_S, "run_as_image")
    img = Image()
    binfo_help = subprocess.run([bin_path, "serve", "--help"], capture_output=True, text=True, timeout=30,
                                env={**{k: v for k, v in os.environ.items() if not k.startswith("HOMCULL_")},
                                     "NO_COLOR": "1"})
    expect(binfo_help.returncode == 0, f"`homcull serve --help` failed: {binfo_help.stderr[-500:]}")
    defaults = dc.parse_clap_help(binfo_help.stdout)
    grace = float(img.env.get("HOMCULL_SHUTDOWN_GRACE_S") or defaults.get("HOMCULL_SHUTDOWN_GRACE_S") or 10)
    expect("HOMCULL_ADDR" in img.env and "HOMCULL_DATA_DIR" in img.env,
           "Dockerfile ENV lacks HOMCULL_ADDR or HOMCULL_DATA_DIR")
    expect(img.env["HOMCULL_DATA_DIR"] in img.volumes,
           f"HOMCULL_DATA_DIR {img.env['HOMCULL_DATA_DIR']} is not a VOLUME ({img.volumes})")
    dc.parse_socket_addr(img.env["HOMCULL_ADDR"])  # must parse; remapped to loopback below
    log(f"image: ENTRYPOINT {img.entrypoint} CMD {img.cmd}, USER {img.uid}:{img.gid}, WORKDIR {img.workdir}, "
        f"STOPSIGNAL {img.stopsignal.name}, HEALTHCHECK {img.healthcheck}, grace {grace:g} s")
    log(f"image ENV: {img.env}")

    root_mode = os.geteuid() == 0
    if root_mode and not shutil.which("setpriv"):
        raise Missing("running as root but `setpriv` (util-linux) is missing: cannot drop to the image's USER")

    tmproot = Path(tempfile.mkdtemp(prefix="homcull-image-"))
    procs = Procs(Path(tempfile.mkdtemp(prefix="homcull-image-logs-")))
    ws = None
    try:
        os.chmod(tmproot, 0o755)
        data = tmproot / "data"
        tmp = tmproot / "tmp"
        bindir = tmproot / Path(img.copied_bin).parent.relative_to("/")
        data.mkdir()
        tmp.mkdir()
        os.chmod(tmp, 0o1777)
        bindir.mkdir(parents=True)
        exe = bindir / Path(img.copied_bin).name
        shutil.copy2(bin_path, exe)
        os.chmod(exe, 0o755)
        if root_mode:
            os.chown(data, img.uid, img.gid)
        os.chmod(data, 0o750)
        remap = path_remapper(tmproot, data, tmp)
        expect(remap(img.env["HOMCULL_DATA_DIR"]) == str(data),
               f"HOMCULL_DATA_DIR {img.env['HOMCULL_DATA_DIR']} is not /data (the VOLUME)")
        port = free_port()
        env = {"PATH": f"{bindir}:{DEFAULT_PATH}", "HOME": "/nonexistent", "HOSTNAME": "homcull-test"}
        for k, v in img.env.items():
            env[k] = remap(v)
        env["HOMCULL_ADDR"] = f"127.0.0.1:{port}"
        for k, v in os.environ.items():
            if k.startswith(PASS_THROUGH) and k not in env:
                env[k] = v
        env.setdefault("WGPU_BACKEND", "vulkan")
        env.setdefault("XDG_RUNTIME_DIR", str(tmp))
        workdir = remap(img.workdir)
        log(f"remapped: HOMCULL_ADDR {img.env['HOMCULL_ADDR']} -> {env['HOMCULL_ADDR']}; "
            f"/data -> {data}; /tmp -> {tmp}; {img.copied_bin} -> {exe}; WORKDIR -> {workdir}")

        # Wrapper: drop to the image's USER; as root also a read-only root file system.
        ro_enforced = False
        if root_mode:
            drop = ["setpriv", f"--reuid={img.uid}", f"--regid={img.gid}", "--clear-groups", "--"]
            probe = subprocess.run(
                ["unshare", "-m", "--propagation", "private", "sh", "-c",
                 'mount --bind "$1" "$1" && mount --bind "$2" "$2" && mount -o remount,bind,ro / '
                 '&& ! touch "$3" 2>/dev/null && touch "$1/.probe" && rm "$1/.probe"',
                 "sh", str(data), str(tmp), str(tmproot / "ro-probe")],
                capture_output=True, text=True, timeout=20) if shutil.which("unshare") else None
            if probe is not None and probe.returncode == 0 and not (tmproot / "ro-probe").exists():
                ro_enforced = True

                def wrap(argv: list[str]) -> list[str]:
                    return ["unshare", "-m", "--propagation", "private", "sh", "-c",
                            'mount --bind "$1" "$1" && mount --bind "$2" "$2" && mount -o remount,bind,ro / '
                            '&& shift 2 && exec "$@"', "sh", str(data), str(tmp), *drop, *argv]
            else:
                why = "unshare missing" if probe is None else (probe.stderr.strip() or f"exit {probe.returncode}")
                log(f"note: no private read-only mount namespace ({why}); checking by snapshots instead")

                def wrap(argv: list[str]) -> list[str]:
                    return [*drop, *argv]
        else:
            log(f"note: not root: running as the current user (uid {os.geteuid()}), not {img.uid}; "
                "read-only root checked by snapshots")

            def wrap(argv: list[str]) -> list[str]:
                return argv

        # Read-only except data and tmp: make the rest of the image root unwritable too,
        # and snapshot it (and the repository's top level) to compare after the run.
        for p in (bindir, *bindir.parents):
            os.chmod(p, 0o555)
            if p == tmproot:
                break
        before_root = snapshot(tmproot, {data, tmp})
        before_repo = sorted(os.listdir(REPO))

        hc_cmd = [*img.healthcheck]
        # Healthcheck with nothing listening must fail (the check is not a no-op).
        r = subprocess.run(wrap(hc_cmd), env=env, cwd=workdir, capture_output=True, text=True, timeout=20)
        expect(r.returncode != 0, "`homcull healthcheck` exited 0 with no server running")

        argv = [*img.entrypoint, *img.cmd]
        t0 = time.monotonic()
        proc = procs.start("homcull", wrap(argv), env, cwd=workdir)
        base = f"http://127.0.0.1:{port}"
        wait_ready(base, proc, min(45.0, dl.left()), "homcull")
        t_ready = time.monotonic() - t0
        log(f"ok    started as the image would ({' '.join(argv)}), ready in {t_ready:.1f} s; "
            f"uid {img.uid if root_mode else os.geteuid()}, read-only root "
            f"{'enforced (private mount namespace)' if ro_enforced else 'checked by snapshot'}")

        # The process really runs as the image's user.
        status = Path(f"/proc/{proc.pid}/status").read_text()
        uids = re.search(r"^Uid:\s+(\d+)\s+(\d+)", status, re.M)
        want_uid = img.uid if root_mode else os.geteuid()
        expect(uids is not None and int(uids.group(1)) == want_uid and int(uids.group(2)) == want_uid,
               f"server runs as uid {uids.groups() if uids else '?'}, expected {want_uid}")
        expect(os.readlink(f"/proc/{proc.pid}/cwd") == workdir,
               f"server cwd {os.readlink(f'/proc/{proc.pid}/cwd')} != WORKDIR {workdir}")

        r = subprocess.run(wrap(hc_cmd), env=env, cwd=workdir, capture_output=True, text=True, timeout=20)
        expect(r.returncode == 0, f"`{' '.join(hc_cmd)}` exited {r.returncode}: {r.stdout}{r.stderr}")
        log(f"ok    HEALTHCHECK `{' '.join(hc_cmd)}` (HOMCULL_ADDR={env['HOMCULL_ADDR']}) exit 0")

        st, body = get_json(f"{base}/healthz")
        expect(st == 200, f"/healthz answered {st}: {body}")
        st, body = get_json(f"{base}/readyz")
        expect(st == 200 and isinstance(body, dict) and body.get("ready") is True,
               f"/readyz answered {st}: {body}")
        adapter = body.get("adapter")
        expect(isinstance(adapter, str) and adapter.strip() != "", f"/readyz names no adapter: {body}")
        if os.environ.get("HOMCULL_REQUIRE_GPU") not in (None, "", "0"):
            expect(body.get("cpu_fallback") is False,
                   f"HOMCULL_REQUIRE_GPU is set but the server fell back to the CPU: {body}")
        log(f"ok    /healthz 200, /readyz 200: adapter {adapter!r}, backend {body.get('backend')}, "
            f"scenes {body.get('scenes')}")
        expect((data / "scenes").is_dir() and (data / "tmp").is_dir(),
               f"the server did not open its data dir at {data} (HOMCULL_DATA_DIR)")

        # A WebSocket client streaming when the stop signal arrives.
        st, scenes = get_json(f"{base}/v1/scenes")
        expect(st == 200 and scenes.get("scenes"), f"no scenes to stream: {st} {scenes}")
        scene_id = "demo" if any(s["id"] == "demo" for s in scenes["scenes"]) else scenes["scenes"][0]["id"]
        ws = WebSocket(port, f"/v1/scenes/{scene_id}/stream", timeout=15)
        hello = recv_frame(ws)
        expect(hello["kind"] == HELLO, f"first frame is not hello: {hello}")
        send_pose(ws, 1, yaw_pose((-60.0, 1.7, 0.0), -1.5707964), want_full=True)
        first = recv_answer(ws, 1)
        expect(first["kind"] == FULL, f"first answer is not a full frame: {first}")
        log(f"ok    WebSocket /v1/scenes/{scene_id}/stream (wire protocol v{ws.version}): hello, "
            f"full frame of {len(first['ids'])} ids")

        t_sig = time.monotonic()
        os.kill(proc.pid, img.stopsignal)
        ws.sock.settimeout(grace + GRACE_MARGIN_S)
        close_code = None
        try:
            while True:
                recv_frame(ws)
        except WsClosed as e:
            close_code, close_reason = e.code, e.reason
        except socket.timeout:
            raise Failed(f"no close frame within {grace + GRACE_MARGIN_S:g} s of {img.stopsignal.name}") from None
        t_close = time.monotonic() - t_sig
        expect(close_code == 1001, f"WebSocket closed with code {close_code} ({close_reason!r}), expected 1001")
        log(f"ok    {img.stopsignal.name}: WebSocket close frame 1001 ({close_reason!r}) after {t_close:.2f} s")
        ws.close()
        ws = None
        try:
            rc = proc.wait(timeout=grace + GRACE_MARGIN_S)
        except subprocess.TimeoutExpired:
            raise Failed(f"still running {grace + GRACE_MARGIN_S:g} s after {img.stopsignal.name} "
                         f"(HOMCULL_SHUTDOWN_GRACE_S {grace:g} + {GRACE_MARGIN_S:g})") from None
        t_exit = time.monotonic() - t_sig
        expect(rc == 0, f"exit code {rc} after {img.stopsignal.name}, expected 0")
        expect(t_exit <= grace + GRACE_MARGIN_S, f"took {t_exit:.1f} s to stop")
        log(f"ok    exited 0 {t_exit:.2f} s after {img.stopsignal.name} "
            f"(limit HOMCULL_SHUTDOWN_GRACE_S {grace:g} s + {GRACE_MARGIN_S:g} s)")
        expect("homcull stopped" in procs.log_tail("homcull", 200), "no `homcull stopped` in the log")

        # Nothing written outside the data dir and the private /tmp.
        after_root = snapshot(tmproot, {data, tmp})
        changed = sorted(k for k in set(before_root) | set(after_root) if before_root.get(k) != after_root.get(k))
        expect(not changed, f"the server wrote outside the data dir and /tmp: {changed}")
        new_repo = sorted(set(os.listdir(REPO)) - set(before_repo))
        expect(not new_repo, f"new entries in the repository after the run: {new_repo}")
        wrote = listing(data)
        cache = listing(tmp)
        log(f"ok    wrote only the data dir ({len(wrote)} files: {', '.join(wrote[:6]) or 'none'}) and /tmp "
            f"({len(cache)} files{', e.g. ' + cache[0] if cache else ''}); image root and repo unchanged")
        log(f"run_as_image: passed in {time.monotonic() - t0:.1f} s")
    except BaseException:
        procs.stop_all()
        procs.dump_logs()
        raise
    finally:
        if ws is not None:
            ws.close()
        procs.stop_all()
        for p in (tmproot, procs.logdir):
            os.chmod(p, 0o755)
            for dirpath, dirnames, _ in os.walk(p):
                for n in dirnames:
                    try:
                        os.chmod(Path(dirpath) / n, 0o755)
                    except OSError:
                        pass
            shutil.rmtree(p, ignore_errors=True)


# --------------------------------------------------------------------------- scale-out behind nginx


def template_upstream_ports() -> list[int]:
    """The loopback ports of the template's one upstream block, in order."""
    text = NGINX_TEMPLATE.read_text()
    conf = dc.parse_nginx(text.replace("@TMP_DIR@", "/x").replace("@LISTEN_PORT@", "1"))
    ups = [u for h in conf.find("http") for u in h.find("upstream")]
    expect(len(ups) == 1, f"the template needs one upstream block, has {len(ups)}")
    ports = []
    for d in ups[0].find("server"):
        h, _, p = d.args[0].rpartition(":")
        expect(h == "127.0.0.1" and p.isdigit(), f"upstream server {d.args[0]} is not 127.0.0.1:PORT")
        ports.append(int(p))
    return ports


def render_nginx(prefix: Path, listen: int, upstream_ports: list[int]) -> str:
    """The template with its placeholders filled and its upstream ports replaced, in order."""
    text = NGINX_TEMPLATE.read_text()
    tmpl_ports = template_upstream_ports()
    expect(len(tmpl_ports) == len(upstream_ports),
           f"the template's upstream has {len(tmpl_ports)} servers, the test runs {len(upstream_ports)}")
    out = text.replace("@TMP_DIR@", str(prefix)).replace("@LISTEN_PORT@", str(listen))
    for old, new in zip(tmpl_ports, upstream_ports):
        if old != new:
            out, n = re.subn(rf"(\bserver\s+127\.0\.0\.1:){old}\b", rf"\g<1>{new}", out)
            expect(n == 1, f"could not substitute upstream port {old}")
    expect("@" not in re.sub(r"#.*", "", out), "a placeholder is left in the nginx config")
    return out


class ProcessLauncher:
    """How `scale_out` starts its replicas and nginx: as processes on this machine
    (tests/container_runtime.py has the same as containers)."""

    what = "processes"

    def __init__(self, bin_path: str):
        self.bin_path = bin_path

    def nginx_binary(self) -> str:
        nginx = find_nginx()
        if nginx is None:
            raise Missing("nginx is not installed (Debian: apt-get install nginx-light or nginx)")
        return nginx

    def shared_data(self, work: Path) -> str:
        shared = work / "data"
        shared.mkdir()
        return str(shared)

    def replica(self, name: str, port: int, shared: str, args: list[str]) -> list[str]:
        return [self.bin_path, "serve", "--addr", f"127.0.0.1:{port}", "--data-dir", shared, *args]

    def nginx(self, nginx: str, prefix: Path, conf: Path) -> list[str]:
        return [nginx, "-p", str(prefix), "-e", str(prefix / "error.log"), "-c", str(conf)]

    def kill(self, name: str, proc: subprocess.Popen) -> None:
        os.kill(proc.pid, signal.SIGKILL)

    def cleanup(self) -> None:
        pass


def scale_out(bin_path: str, launcher: ProcessLauncher | None = None) -> None:
    dl = Deadline(TIME_LIMIT_S, "scale_out")
    launcher = launcher or ProcessLauncher(bin_path)
    nginx = launcher.nginx_binary()
    work = Path(tempfile.mkdtemp(prefix="homcull-scale-"))
    os.chmod(work, 0o755)  # nginx workers drop to `nobody` when the master runs as root
    procs = Procs(work)
    ws = None
    t0 = time.monotonic()
    try:
        shared = launcher.shared_data(work)
        ngx = work / "nginx"
        ngx.mkdir()

        # Ports: the template's upstream ports when free, else free ones substituted.
        tmpl_ports = template_upstream_ports()
        ports = tmpl_ports if all(port_free(p) for p in tmpl_ports) else [free_port() for _ in tmpl_ports]
        expect(len(set(ports)) == len(ports), "port collision")
        listen = free_port()
        conf_text = render_nginx(ngx, listen, ports)
        conf = ngx / "nginx.conf"
        conf.write_text(conf_text)
        log(f"nginx {nginx} on 127.0.0.1:{listen}; upstream ports {ports}"
            + ("" if ports == tmpl_ports else f" (template's {tmpl_ports} were busy, substituted)"))

        glb: bytes | None = SHARED_GLB.read_bytes() if SHARED_GLB.is_file() else None
        env = base_server_env()
        reps = []
        for i, p in enumerate(ports):
            # Replicas on one volume keep placements in memory (one journal per data dir).
            args = ["--rescan-s", "1", "--ws-max-fps", "1000", "--state", "memory"]
            if glb is not None or i > 0:
                args.append("--no-demo")  # the demo is only needed as a GLB source
            name = f"replica{i + 1}"
            reps.append((name, p, procs.start(name, launcher.replica(name, p, shared, args), env)))
        for name, p, proc in reps:
            wait_ready(f"http://127.0.0.1:{p}", proc, min(45.0, dl.left()), name)
        log(f"ok    3 replicas ready as {launcher.what} in {time.monotonic() - t0:.1f} s "
            f"(data {shared}, rescan 1 s)")

        if glb is None:
            st, _, glb = http("GET", f"http://127.0.0.1:{ports[0]}/v1/scenes/demo/glb")
            expect(st == 200, f"GET /v1/scenes/demo/glb answered {st}")
            src = "the demo city's GLB"
        else:
            src = str(SHARED_GLB)

        nproc = procs.start("nginx", launcher.nginx(nginx, ngx, conf), dict(os.environ))
        front = f"http://127.0.0.1:{listen}"
        wait_for(lambda: nproc.poll() is None and http("GET", f"{front}/healthz", timeout=3)[0] == 200,
                 15, "nginx to proxy /healthz")
        if nproc.poll() is not None:
            raise Failed(f"nginx exited {nproc.returncode}: {(ngx / 'error.log').read_text()[-2000:]}")

        # Upload through nginx; every replica picks it up from the shared dir.
        t = time.monotonic()
        st, _, body = http("POST", f"{front}/v1/scenes?name=scale-out-test", glb, "model/gltf-binary", timeout=60)
        expect(st == 201, f"upload through nginx answered {st}: {body[:500]!r}")
        info = json.loads(body)
        sid = info["id"]
        log(f"ok    uploaded {src} ({len(glb)} B) through nginx in {time.monotonic() - t:.1f} s: "
            f"id {sid}, {info['objects']} objects")

        def everywhere():
            for _, p, _ in reps:
                st, lst = get_json(f"http://127.0.0.1:{p}/v1/scenes", timeout=5)
                if st != 200 or not any(s["id"] == sid for s in lst["scenes"]):
                    return False
            return True

        wait_for(everywhere, min(30.0, dl.left()), f"all replicas to list scene {sid}", every=0.2)
        log(f"ok    all 3 replicas list {sid} {time.monotonic() - t:.1f} s after the upload started")

        # The same cull on each replica, directly: identical answers.
        lo, hi = info["bounds"]
        cx, cz = (lo[0] + hi[0]) / 2, (lo[2] + hi[2]) / 2
        sx, sz = (hi[0] - lo[0]) / 2, (hi[2] - lo[2]) / 2
        y = lo[1] + 1.7
        poses = [yaw_pose((cx + a * sx, y, cz + b * sz), yaw)
                 for a, b, yaw in ((-0.5, 0.0, -1.5707964), (0.0, 0.45, 0.0), (0.3, -0.3, 2.356),
                                   (0.0, 0.0, 0.785), (-0.2, -0.6, 3.1415927))]
        deterministic = ("objects", "candidates", "culled_by_frustum", "culled_by_occlusion", "occluders_used",
                         "occluder_triangles")
        answers = []
        for _, p, _ in reps:
            st, res = post_json(f"http://127.0.0.1:{p}/v1/scenes/{sid}/cull/batch", {"poses": poses})
            expect(st == 200, f"cull/batch on :{p} answered {st}: {res}")
            answers.append([(r["visible"], {k: r["stats"][k] for k in deterministic}) for r in res["results"]])
        for i, a in enumerate(answers[1:], 2):
            expect(a == answers[0], f"replica{i} answers the same cull differently from replica1")
        vis = [len(v) for v, _ in answers[0]]
        occl = sum(s["culled_by_occlusion"] for _, s in answers[0])
        expect(any(vis), "every pose sees nothing: the comparison would be vacuous")
        log(f"ok    {len(poses)} poses culled on each replica directly: identical visible sets {vis} "
            f"and stats ({occl} culled by occlusion in all)")

        # A WebSocket stream through nginx; the replica serving it is killed mid-stream.
        def rest_cull(port: int, pose: dict) -> list[int]:
            # The stream's default options: HOM's box test without the refinement.
            st, res = post_json(f"http://127.0.0.1:{port}/v1/scenes/{sid}/cull",
                                {"pose": pose, "options": {"refine": False}})
            expect(st == 200, f"cull on :{port} answered {st}: {res}")
            return res["visible"]

        walk = [yaw_pose((cx + (-0.6 + 1.2 * k / 40) * sx, y, cz + 0.05 * sz), -1.5707964 + 0.3 * (k % 7) / 7)
                for k in range(41)]
        path = f"/v1/scenes/{sid}/stream"
        ws = WebSocket(listen, path, timeout=15)
        hello = recv_frame(ws)
        expect(hello["kind"] == HELLO and hello["info"]["scene"]["id"] == sid, f"bad hello {hello}")
        visible: list[int] = []
        seq = 0
        for k in range(5):
            seq += 1
            send_pose(ws, seq, walk[k])
            visible = apply(visible, recv_answer(ws, seq))
        serving = wait_for(lambda: [r for r in reps if metric(f"http://127.0.0.1:{r[1]}", "homcull_ws_clients") >= 1],
                           10, "a replica to report the WebSocket client in homcull_ws_clients")
        expect(len(serving) == 1, f"{len(serving)} replicas report the one WebSocket client")
        victim_name, victim_port, victim = serving[0]
        expect(visible == rest_cull(victim_port, walk[4]),
               "the stream's visible set (full + deltas) differs from a REST cull of the same pose")
        log(f"ok    WebSocket through nginx (wire protocol v{ws.version}) on {victim_name} (:{victim_port}, "
            f"homcull_ws_clients 1): 5 poses, deltas applied == REST cull")

        # Keep streaming; SIGKILL the serving replica with a pose in flight.
        seq += 1
        send_pose(ws, seq, walk[5])
        launcher.kill(victim_name, victim)
        t_kill = time.monotonic()
        victim.wait(timeout=10)
        ws.sock.settimeout(10)
        noticed = None
        try:
            k = 6
            while time.monotonic() - t_kill < 10:
                try:
                    recv_frame(ws)
                except socket.timeout:
                    break
                seq += 1
                send_pose(ws, seq, walk[k % len(walk)])
                k += 1
        except WsClosed as e:
            noticed = e
        except OSError as e:  # broken pipe on send
            noticed = WsClosed(None, f"{type(e).__name__}: {e}")
        expect(noticed is not None, "the client did not notice that its replica died within 10 s")
        t_notice = time.monotonic() - t_kill
        ws.close()
        ws = None
        log(f"ok    SIGKILL {victim_name}: client noticed the close after {t_notice:.2f} s ({noticed.reason})")

        # Reconnect through nginx: another replica, a full frame on request, and on.
        t = time.monotonic()
        ws = WebSocket(listen, path, timeout=15)
        hello = recv_frame(ws)
        expect(hello["kind"] == HELLO, f"bad hello after reconnect {hello}")
        t_reconnect = time.monotonic() - t
        survivors = [r for r in reps if r[2] is not victim]
        seq += 1
        send_pose(ws, seq, walk[20], want_full=True)
        full = recv_answer(ws, seq)
        expect(full["kind"] == FULL, f"asked for a full frame, got kind {full['kind']}")
        now_serving = [r for r in survivors if metric(f"http://127.0.0.1:{r[1]}", "homcull_ws_clients") >= 1]
        expect(len(now_serving) == 1, f"after the reconnect {len(now_serving)} surviving replicas hold the client")
        new_name, new_port, _ = now_serving[0]
        want = rest_cull(new_port, walk[20])
        expect(full["ids"] == want, f"full frame after reconnect ({len(full['ids'])} ids) != REST cull "
                                    f"({len(want)} ids)")
        other = next(r for r in survivors if r[1] != new_port)
        expect(rest_cull(other[1], walk[20]) == want, "the surviving replicas disagree on the reconnect pose")
        visible = full["ids"]
        for k in range(21, 26):
            seq += 1
            send_pose(ws, seq, walk[k])
            visible = apply(visible, recv_answer(ws, seq))
        expect(visible == rest_cull(new_port, walk[25]), "the stream after the reconnect drifted from REST")
        log(f"ok    reconnected through nginx in {t_reconnect:.2f} s to {new_name} (:{new_port}); full frame "
            f"({len(full['ids'])} ids) == REST cull; 5 more poses as deltas == REST")
        ws.close()
        ws = None

        elog = (ngx / "error.log").read_text(errors="replace")
        refused = len(re.findall(r"Connection refused", elog))
        log(f"      nginx error.log: {refused} 'connection refused' to the dead replica (expected >= 1)")
        log(f"scale_out: passed in {time.monotonic() - t0:.1f} s")
    except BaseException:
        procs.stop_all()
        procs.dump_logs()
        if (work / "nginx" / "error.log").exists():
            log("  --- nginx error.log tail:\n" + "\n".join(
                "    " + ln for ln in (work / "nginx" / "error.log").read_text(errors="replace").splitlines()[-25:]))
        raise
    finally:
        if ws is not None:
            ws.close()
        procs.stop_all()
        launcher.cleanup()
        shutil.rmtree(work, ignore_errors=True)


# --------------------------------------------------------------------------- main

CHECKS = {"run_as_image": run_as_image, "scale_out": scale_out}


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--bin", default=str(REPO / "target" / "release" / "homcull"), help="the homcull binary")
    ap.add_argument("--only", choices=sorted(CHECKS), action="append", help="run only this check (repeatable)")
    args = ap.parse_args()
    bin_path = str(Path(args.bin).resolve())
    if not os.access(bin_path, os.X_OK):
        print(f"binary {bin_path} not found: cargo build --release --bin homcull", file=sys.stderr)
        return 2

    def alarm(*_):
        raise Failed(f"the check took longer than {TIME_LIMIT_S:.0f} s")

    signal.signal(signal.SIGALRM, alarm)
    try:
        log(f"ok    {check_codec()}")
    except Failed as e:
        log(f"FAIL  the WebSocket codec of this script: {e}")
        return 1
    names = args.only or list(CHECKS)
    failed, missing = [], []
    for name in names:
        log(f"== {name} ({bin_path})")
        signal.alarm(int(TIME_LIMIT_S))
        t = time.monotonic()
        try:
            CHECKS[name](bin_path)
        except Missing as e:
            log(f"MISSING {name}: {e}")
            missing.append(name)
        except Failed as e:
            log(f"FAIL  {name} after {time.monotonic() - t:.1f} s: {e}")
            failed.append(name)
        except Exception:  # noqa: BLE001
            log(f"FAIL  {name} after {time.monotonic() - t:.1f} s:\n{traceback.format_exc()}")
            failed.append(name)
        finally:
            signal.alarm(0)
    log(f"deploy_runtime: {len(names) - len(failed) - len(missing)} passed, {len(failed)} failed, "
        f"{len(missing)} missing prerequisites")
    return 1 if failed else (2 if missing else 0)


if __name__ == "__main__":
    sys.exit(main())
