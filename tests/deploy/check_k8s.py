#!/usr/bin/python3
"""Offline check of the Kubernetes manifests in deploy/k8s/.

    check_k8s.py SERVER_BINARY K8S_DIR              check every overlay
    check_k8s.py --self-test SERVER_BINARY K8S_DIR  break them on purpose

Renders each overlay (every folder of K8S_DIR with a kustomization.yaml but
base/) with the small part of kustomize the manifests use, and, when a
kubectl with kustomize v4 or later is on the PATH, also with `kubectl
kustomize` and compares the two. Then checks what a cluster would only
show at run time: flags the server does not know (from SERVER_BINARY
--helpfull), ports and probes that miss the ports the flags open, memory
limits that do not follow from --max_missions, selectors that select
nothing, Secrets and files that are not there, and the proxy's routing.

One line per check, then 'N passed, N failed'; exit 1 on any failure.
--self-test breaks a copy of the rendered manifests in memory, one fault at
a time, and fails unless the check meant to catch each fault does.

Needs only Python 3 and PyYAML (Debian: python3-yaml); no cluster, no
network.
"""

import base64
import copy
import ipaddress
import json
import os
import re
import shutil
import subprocess
import sys

import yaml

# Memory of one mission as admission counts it (EstimateMissionBytes: the
# E1 map and ESDF twice each, 2 x 20.5 + 2 x 16.2 = 73.4 MB), and what the
# process needs beside its missions; base/flags.yaml explains both.
MISSION_MIB = 74
PROCESS_MIB = 300

# The server's container: by its name, or by its image (deploy/container/
# Containerfile's image holds oaipp-server and oaipp-client).
SERVER = "oaipp-server"
SERVER_IMAGES = ("oaipp-server", "oaipp")
MISSION_HEADER = "x-oaipp-mission"
MISSION_SERVICE = "oaipp.v1.MissionService"

# Flags whose value names a file the server reads.
FILE_FLAGS = ("tls_cert", "tls_key", "tls_client_ca", "token_file")

# Abseil's defaults for the flags the checks read, as server/main.cc has them.
DEFAULTS = {
    "listen": "127.0.0.1:50051",
    "metrics_listen": "127.0.0.1:9464",
    "store": "sqlite",
    "data_dir": "./data",
    "planning_threads": "2",
    "max_memory_mb": "0",
    "shutdown_grace_s": "10",
    "reflection": "true",
    "max_missions": "64",
    "max_missions_per_tenant": "0",
    "max_plans_per_tenant": "0",
    "planning_queue": "16",
}

WORKLOAD_KINDS = ("Deployment", "StatefulSet", "DaemonSet", "ReplicaSet")


class Unsupported(Exception):
    """A kustomize feature the built-in renderer does not implement."""


# ---------------------------------------------------------------------------
# The part of kustomize the manifests use: resources (files and folders),
# patches (strategic merge, or JSON 6902 with a target) and the older
# patchesStrategicMerge. Anything else is refused rather than ignored, so a
# manifest using more cannot be checked against a wrong rendering.


class Res:
    """One rendered document, with the files it came from."""

    def __init__(self, doc, origin):
        self.doc = doc
        self.origin = origin  # the resource file, relative to K8S_DIR
        self.patches = []  # the patch files applied to it

    def where(self):
        files = " + ".join([self.origin] + self.patches)
        return f"{kind_name(self.doc)} ({files})"


def kind_name(doc):
    meta = doc.get("metadata") or {}
    return f"{doc.get('kind', '?')}/{meta.get('name', '?')}"


# Strategic merge: lists of these fields merge item by item on this key
# (Kubernetes' patchMergeKey); other lists are replaced whole.
MERGE_KEYS = {
    "containers": "name",
    "initContainers": "name",
    "volumes": "name",
    "volumeMounts": "mountPath",
    "env": "name",
    "imagePullSecrets": "name",
    "topologySpreadConstraints": "topologyKey",
}


def merge_key(field, items):
    if field == "ports":
        dicts = [i for i in items if isinstance(i, dict)]
        if dicts and all("containerPort" in i for i in dicts):
            return "containerPort"
        return "port"
    return MERGE_KEYS.get(field)


def strategic_merge(base, patch, field=None):
    if isinstance(patch, dict):
        if any(isinstance(k, str) and k.startswith("$") for k in patch):
            raise Unsupported(f"strategic-merge directive in {sorted(patch)}")
        if not isinstance(base, dict):
            return copy.deepcopy(patch)
        out = dict(base)
        for key, value in patch.items():
            if value is None:
                out.pop(key, None)
            elif key in out:
                out[key] = strategic_merge(out[key], value, key)
            else:
                out[key] = strip_nulls(copy.deepcopy(value))
        return out
    if isinstance(patch, list) and isinstance(base, list):
        key = merge_key(field, base + patch)
        if key is None or not all(isinstance(i, dict) for i in base + patch):
            return strip_nulls(copy.deepcopy(patch))
        out = [copy.deepcopy(i) for i in base]
        for item in patch:
            if any(isinstance(k, str) and k.startswith("$") for k in item):
                raise Unsupported(f"strategic-merge directive in {field}")
            hits = [n for n, old in enumerate(out) if old.get(key) == item.get(key)]
            if hits:
                out[hits[0]] = strategic_merge(out[hits[0]], item, field)
            else:
                out.append(strip_nulls(copy.deepcopy(item)))
        return out
    return strip_nulls(copy.deepcopy(patch))


def strip_nulls(value):
    if isinstance(value, dict):
        return {k: strip_nulls(v) for k, v in value.items() if v is not None}
    if isinstance(value, list):
        return [strip_nulls(v) for v in value]
    return value


def json_pointer(doc, pointer):
    parts = [p.replace("~1", "/").replace("~0", "~") for p in pointer.split("/")[1:]]
    parent = doc
    for part in parts[:-1]:
        parent = parent[int(part)] if isinstance(parent, list) else parent[part]
    return parent, parts[-1]


def json6902(doc, ops):
    doc = copy.deepcopy(doc)
    for op in ops:
        parent, last = json_pointer(doc, op["path"])
        kind = op["op"]
        if isinstance(parent, list):
            index = len(parent) if last == "-" else int(last)
            if kind == "add":
                parent.insert(index, copy.deepcopy(op["value"]))
            elif kind == "replace":
                parent[index] = copy.deepcopy(op["value"])
            elif kind == "remove":
                del parent[index]
            else:
                raise Unsupported(f"JSON 6902 op {kind}")
        else:
            if kind in ("add", "replace"):
                if kind == "replace" and last not in parent:
                    raise KeyError(op["path"])
                parent[last] = copy.deepcopy(op["value"])
            elif kind == "remove":
                del parent[last]
            else:
                raise Unsupported(f"JSON 6902 op {kind}")
    return doc


def load_yaml_docs(path):
    with open(path, encoding="utf-8") as f:
        docs = [d for d in yaml.safe_load_all(f) if d is not None]
    for n, d in enumerate(docs):
        if not isinstance(d, (dict, list)):
            raise ValueError(f"{path}: document {n + 1} is not a mapping")
    return docs


def matches_target(doc, target):
    meta = doc.get("metadata") or {}
    if "kind" in target and doc.get("kind") != target["kind"]:
        return False
    if "name" in target and meta.get("name") != target["name"]:
        return False
    if "namespace" in target and meta.get("namespace") != target["namespace"]:
        return False
    if "group" in target or "version" in target:
        api = doc.get("apiVersion", "")
        group, _, version = api.rpartition("/")
        if target.get("group", group) != group or target.get("version", version) != version:
            return False
    return not target.get("labelSelector") and not target.get("annotationSelector")


def render(folder, root):
    """The documents `kubectl kustomize folder` would print, as Res."""
    path = os.path.join(folder, "kustomization.yaml")
    with open(path, encoding="utf-8") as f:
        kust = yaml.safe_load(f) or {}
    known = {"apiVersion", "kind", "resources", "patches", "patchesStrategicMerge", "images"}
    extra = sorted(set(kust) - known)
    if extra:
        raise Unsupported(f"{os.path.relpath(path, root)}: {', '.join(extra)}")
    out = []
    for entry in kust.get("resources") or []:
        target = os.path.normpath(os.path.join(folder, entry))
        if os.path.isdir(target):
            out.extend(render(target, root))
        else:
            for doc in load_yaml_docs(target):
                out.append(Res(doc, os.path.relpath(target, root)))
    patches = [{"path": p} for p in kust.get("patchesStrategicMerge") or []]
    patches += kust.get("patches") or []
    for patch in patches:
        if "path" in patch:
            patch_path = os.path.join(folder, patch["path"])
            label = os.path.relpath(patch_path, root)
            docs = load_yaml_docs(patch_path)
        elif "patch" in patch:
            label = f"{os.path.relpath(path, root)} (inline patch)"
            docs = [d for d in yaml.safe_load_all(patch["patch"]) if d is not None]
        else:
            raise Unsupported(f"{os.path.relpath(path, root)}: a patch without path or patch")
        options = patch.get("options") or {}
        if set(options) - {"allowKindChange"}:
            raise Unsupported(f"{label}: patch options {sorted(set(options) - {'allowKindChange'})}")
        if len(docs) == 1 and isinstance(docs[0], list):
            # JSON 6902 operations, applied to the target.
            target = patch.get("target")
            if not target:
                raise Unsupported(f"{label}: JSON 6902 patch without a target")
            if any(op.get("path") == "/kind" for op in docs[0]) and \
                    not options.get("allowKindChange"):
                # kustomize refuses such a patch without the option.
                raise ValueError(f"{label}: changes /kind without options.allowKindChange")
            hits = [r for r in out if matches_target(r.doc, target)]
            if not hits:
                raise ValueError(f"{label}: the target {target} matches no resource")
            for r in hits:
                r.doc = json6902(r.doc, docs[0])
                r.patches.append(label)
            continue
        for pdoc in docs:
            target = dict(patch.get("target") or {})
            target.setdefault("kind", pdoc.get("kind"))
            target.setdefault("name", (pdoc.get("metadata") or {}).get("name"))
            hits = [r for r in out if matches_target(r.doc, target)]
            if not hits:
                raise ValueError(f"{label}: {kind_name(pdoc)} matches no resource")
            for r in hits:
                r.doc = strategic_merge(r.doc, pdoc)
                r.patches.append(label)
    for image in kust.get("images") or []:
        for r in out:
            spec = pod_spec(r.doc)
            for c in (spec.get("containers") or []) + (spec.get("initContainers") or []):
                c["image"] = retag(c.get("image", ""), image)
    return out


def retag(ref, image):
    """kustomize's images: entry applied to one image reference."""
    name, digest = ref.split("@", 1) if "@" in ref else (ref, None)
    tag = None
    if ":" in name.rsplit("/", 1)[-1]:
        name, tag = name.rsplit(":", 1)
    if name != image.get("name"):
        return ref
    name = image.get("newName", name)
    if image.get("digest"):
        return f"{name}@{image['digest']}"
    tag = image.get("newTag", tag)
    if "newTag" not in image and digest:
        return f"{name}@{digest}"
    return f"{name}:{tag}" if tag else name


def canonical(value):
    """For comparing renderings: lists of mappings in a fixed order (strategic
    merge puts new items first or last, which means nothing)."""
    if isinstance(value, dict):
        return {k: canonical(v) for k, v in value.items()}
    if isinstance(value, list):
        items = [canonical(v) for v in value]
        if items and all(isinstance(i, dict) for i in items):
            items.sort(key=lambda i: json.dumps(i, sort_keys=True))
        return items
    return value


def kubectl_kustomize_version():
    kubectl = shutil.which("kubectl")
    if kubectl is None:
        return None, "kubectl not found"
    try:
        run = subprocess.run([kubectl, "version", "--client", "-o", "json"], capture_output=True,
                             text=True, timeout=60, check=False)
        version = json.loads(run.stdout).get("kustomizeVersion", "")
    except (OSError, ValueError, subprocess.TimeoutExpired) as e:
        return None, f"kubectl version: {e}"
    m = re.match(r"v?(\d+)\.", version or "")
    if not m or int(m.group(1)) < 4:
        # kubectl before 1.21 (Debian 12's kubernetes-client is 1.20) carries
        # kustomize 2, which has no `patches:`.
        return None, f"kubectl's kustomize is {version or 'unknown'}, older than v4"
    return kubectl, version


# ---------------------------------------------------------------------------
# What the checks read from a rendering.


def pod_spec(doc):
    return (((doc.get("spec") or {}).get("template") or {}).get("spec")) or {}


def pod_labels(doc):
    return ((((doc.get("spec") or {}).get("template") or {}).get("metadata") or {})
            .get("labels")) or {}


def workloads(resources):
    return [r for r in resources if r.doc.get("kind") in WORKLOAD_KINDS]


def image_name(image):
    """localhost/oaipp-server:latest -> oaipp-server."""
    return (image or "").split("@")[0].rsplit("/", 1)[-1].split(":")[0]


def is_server(container):
    return container.get("name") == SERVER or image_name(container.get("image")) in SERVER_IMAGES


def image_entrypoint(root):
    """The flags of the image's ENTRYPOINT (deploy/container/Containerfile),
    which come before a pod's args; [] without a Containerfile."""
    path = os.path.join(root, os.pardir, "container", "Containerfile")
    if not os.path.isfile(path):
        return []
    with open(path, encoding="utf-8") as f:
        text = re.sub(r"\\\n", " ", f.read())
    entry = [m for m in re.findall(r"^ENTRYPOINT\s+(\[.*\])\s*$", text, re.M)]
    if not entry:
        return []
    argv = json.loads(entry[-1])
    if os.path.basename(argv[0]) != SERVER:
        raise RuntimeError(f"{path}: ENTRYPOINT runs {argv[0]}, not {SERVER}")
    return argv[1:]


def find(resources, kind, name):
    for r in resources:
        if r.doc.get("kind") == kind and (r.doc.get("metadata") or {}).get("name") == name:
            return r
    return None


def host_port(address):
    """'0.0.0.0:50051' -> ('0.0.0.0', 50051); '[::]:1' -> ('::', 1)."""
    host, _, port = address.rpartition(":")
    if host.startswith("[") and host.endswith("]"):
        host = host[1:-1]
    return host, int(port) if port.isdigit() else None


def is_loopback(host):
    if host == "localhost":
        return True
    try:
        return ipaddress.ip_address(host).is_loopback
    except ValueError:
        return False


def mib(quantity):
    """A Kubernetes memory quantity in MiB (None when it does not parse)."""
    m = re.fullmatch(r"([0-9.]+)([KMGTPE]i?|e[0-9]+)?", str(quantity))
    if not m:
        return None
    scale = {None: 1, "Ki": 2**10, "Mi": 2**20, "Gi": 2**30, "Ti": 2**40, "K": 1e3, "M": 1e6,
             "G": 1e9, "T": 1e12}
    unit = m.group(2)
    factor = 10 ** int(unit[1:]) if unit and unit.startswith("e") else scale.get(unit)
    if factor is None:
        return None
    return float(m.group(1)) * factor / 2**20


def cpu_cores(quantity):
    text = str(quantity)
    try:
        return float(text[:-1]) / 1000 if text.endswith("m") else float(text)
    except ValueError:
        return None


def secret_values(doc):
    values = {}
    for key, value in (doc.get("data") or {}).items():
        try:
            values[key] = base64.b64decode(str(value)).decode("utf-8", "replace")
        except ValueError:
            values[key] = str(value)
    for key, value in (doc.get("stringData") or {}).items():
        values[key] = str(value)
    return values


def volume_files(resources, volume):
    """(source description, {file name in the volume: (key, content)}, kind)
    of a ConfigMap or Secret volume; kind is 'configMap', 'secret', 'claim',
    'emptyDir' or 'other'. The files are None when the object is missing."""
    if "configMap" in volume or "secret" in volume:
        is_secret = "secret" in volume
        src = volume["secret"] if is_secret else volume["configMap"]
        name = src.get("secretName") if is_secret else src.get("name")
        kind = "Secret" if is_secret else "ConfigMap"
        r = find(resources, kind, name)
        if r is None:
            return f"{kind}/{name}", None, "secret" if is_secret else "configMap"
        data = secret_values(r.doc) if is_secret else dict(r.doc.get("data") or {})
        if src.get("items"):
            files = {i["path"]: (i["key"], data.get(i["key"])) for i in src["items"]}
        else:
            files = {k: (k, v) for k, v in data.items()}
        return r.where(), files, "secret" if is_secret else "configMap"
    if "persistentVolumeClaim" in volume:
        claim = volume["persistentVolumeClaim"].get("claimName")
        return f"PersistentVolumeClaim/{claim}", {}, "claim"
    if "emptyDir" in volume:
        return f"emptyDir {volume.get('name')}", {}, "emptyDir"
    return f"volume {volume.get('name')}", {}, "other"


def resolve_path(resources, spec, container, path):
    """What a container finds at `path`: (kind, description, content, error).
    kind as volume_files; content for ConfigMap and Secret files."""
    mounts = sorted(container.get("volumeMounts") or [], key=lambda m: -len(m["mountPath"]))
    volumes = {v.get("name"): v for v in spec.get("volumes") or []}
    for mount in mounts:
        mp = mount["mountPath"].rstrip("/")
        if path != mp and not path.startswith(mp + "/"):
            continue
        volume = volumes.get(mount.get("name"))
        if volume is None:
            return None, None, None, (f"volumeMount {mount['mountPath']} names no volume "
                                      f"{mount.get('name')!r}")
        rel = path[len(mp):].lstrip("/")
        if mount.get("subPath"):
            rel = os.path.join(mount["subPath"], rel).rstrip("/")
        where, files, kind = volume_files(resources, volume)
        if files is None:
            return kind, where, None, (f"{where} (volume {volume.get('name')}) is not in the "
                                       "manifests")
        if kind in ("configMap", "secret"):
            if rel not in files:
                return kind, where, None, (f"{path}: volume {volume.get('name')} ({where}) has no "
                                           f"file {rel!r} (it has {sorted(files)})")
            key, content = files[rel]
            if content is None:
                return kind, where, None, f"{path}: {where} has no key {key!r}"
            return kind, f"{where} key {key}", content, None
        return kind, where, None, None
    return None, None, None, f"{path} is on no volume of the container (the root filesystem)"


def parse_flag(text):
    """'--name=value' -> (name, value); '--name' -> (name, None)."""
    body = text[2:] if text.startswith("--") else text[1:]
    name, eq, value = body.partition("=")
    return name, (value if eq else None)


class Server:
    """The oaipp-server workload of an overlay and the flags it runs with."""

    def __init__(self, resources, res, bool_flags, entrypoint):
        self.res = res
        self.doc = res.doc
        self.spec = pod_spec(res.doc)
        self.container = next(c for c in self.spec.get("containers") or [] if is_server(c))
        self.entrypoint = entrypoint
        self.env = {e.get("name"): e for e in self.container.get("env") or []}
        self.errors = []  # flags that cannot be read at all
        self.flags = []  # (name, value, where), in the order Abseil reads them
        self.env_sources = {}  # flag name -> the env entry its value came from
        self._read(resources)
        self.values = {}
        for name, value, _ in self.flags:
            if value is None and name.startswith("no") and name[2:] in bool_flags:
                self.values[name[2:]] = "false"
            else:
                self.values[name] = "true" if value is None else value

    def get(self, name):
        return self.values.get(name, DEFAULTS.get(name))

    def bool(self, name):
        return str(self.values.get(name, "false")).lower() in ("true", "1", "yes", "t", "y")

    def env_value(self, name, resources):
        """(value, source) of an env var; source 'secret', 'configMap', 'literal', 'field'."""
        entry = self.env.get(name)
        if entry is None:
            return None, None
        if "value" in entry:
            return str(entry["value"]), "literal"
        ref = entry.get("valueFrom") or {}
        if "secretKeyRef" in ref:
            r = find(resources, "Secret", ref["secretKeyRef"].get("name"))
            key = ref["secretKeyRef"].get("key")
            return (secret_values(r.doc).get(key) if r else None), "secret"
        if "configMapKeyRef" in ref:
            r = find(resources, "ConfigMap", ref["configMapKeyRef"].get("name"))
            return ((r.doc.get("data") or {}).get(ref["configMapKeyRef"].get("key")) if r else None,
                    "configMap")
        return f"<{name}>", "field"

    def _read(self, resources):
        where_args = (f"{self.res.where()} spec.template.spec.containers"
                      f"[{self.container.get('name')}]")
        if self.container.get("command"):
            self.errors.append(f"{where_args}.command replaces the image's entrypoint (the server)")
        for n, arg in enumerate(self.entrypoint):
            self._flag(arg, f"the image's ENTRYPOINT[{n + 1}] (deploy/container/Containerfile)",
                       resources)
        for n, arg in enumerate(self.container.get("args") or []):
            where = f"{where_args}.args[{n}]"
            arg = str(arg)

            def expand(m):
                value, _ = self.env_value(m.group(1), resources)
                if value is None:
                    self.errors.append(f"{where}: $({m.group(1)}) is no env var of the container "
                                       "(the kubelet would pass it literally)")
                    return m.group(0)
                return value

            expanded = re.sub(r"\$\(([A-Za-z_][A-Za-z0-9_]*)\)", expand, arg)
            if not arg.startswith("-"):
                self.errors.append(f"{where}: {arg!r} is not a flag")
                continue
            self._flag(expanded, where, resources, raw=arg)

    def _flag(self, text, where, resources, raw=None):
        name, value = parse_flag(text)
        self.flags.append((name, value, where))
        if raw is not None:
            m = re.search(r"\$\(([A-Za-z_][A-Za-z0-9_]*)\)", raw)
            if m and m.group(1) in self.env:
                self.env_sources[name] = self.env[m.group(1)]
        if name == "flagfile" and value:
            for path in value.split(","):
                _, desc, content, error = resolve_path(resources, self.spec, self.container,
                                                       path)
                if error:
                    self.errors.append(f"{where}: --flagfile {error}")
                    continue
                if content is None:
                    self.errors.append(f"{where}: --flagfile {path} is on {desc}, not a ConfigMap")
                    continue
                for line_no, line in enumerate(str(content).split("\n"), 1):
                    stripped = line.lstrip()
                    if not stripped or stripped.startswith("#"):
                        continue
                    lwhere = f"{desc} line {line_no}"
                    if not stripped.startswith("-"):
                        self.errors.append(f"{lwhere}: {stripped!r} is not a flag (Abseil stops "
                                           "at it: 'Unexpected line in the flagfile')")
                        continue
                    if stripped != stripped.rstrip():
                        self.errors.append(f"{lwhere}: trailing blanks become part of the value")
                    self._flag(stripped, lwhere, resources)
        elif name in ("fromenv", "tryfromenv") and value:
            for flag in value.split(","):
                env_value, source = self.env_value(f"FLAGS_{flag}", resources)
                if env_value is None:
                    if name == "fromenv":
                        self.errors.append(f"{where}: --fromenv={flag} needs the env var "
                                           f"FLAGS_{flag}, which the container does not set (or "
                                           "whose source is missing)")
                    continue
                self.flags.append((flag, env_value, f"{where} (env FLAGS_{flag} from {source})"))
                self.env_sources[flag] = self.env[f"FLAGS_{flag}"]


def parse_help(binary):
    """Flag names (and the bool ones) from `binary --helpfull`."""
    run = subprocess.run([binary, "--helpfull"], capture_output=True, text=True, timeout=60,
                         check=False)
    text = run.stdout + run.stderr
    # A flag starts a line indented by four blanks; its description goes on
    # at six, where a word like --store may also start a line.
    starts = list(re.finditer(r"^    --([A-Za-z0-9_]+) \(", text, re.M))
    names, bools = set(), set()
    for n, m in enumerate(starts):
        block = text[m.start():starts[n + 1].start() if n + 1 < len(starts) else len(text)]
        names.add(m.group(1))
        default = re.findall(r"default:\s*([^;]*);", block)
        if default and default[-1].strip() in ("true", "false"):
            bools.add(m.group(1))
    if "listen" not in names or "flagfile" not in names:
        raise RuntimeError(f"{binary} --helpfull lists no --listen/--flagfile; is it oaipp-server?")
    return names, bools


# ---------------------------------------------------------------------------
# HAProxy's configuration, as far as the checks read it.


def parse_haproxy(text):
    """{(section, name): [[word, ...], ...]} with comments dropped."""
    sections = {}
    current = None
    for line in text.split("\n"):
        line = line.split("#", 1)[0].strip() if not line.strip().startswith("#") else ""
        if not line:
            continue
        words = re.findall(r'"[^"]*"|\S+', line)
        words = [w[1:-1] if w.startswith('"') else w for w in words]
        if words[0] in ("global", "defaults", "frontend", "backend", "listen", "resolvers",
                        "peers", "userlist", "program", "http-errors", "cache", "ring"):
            current = (words[0], words[1] if len(words) > 1 else "")
            sections[current] = []
        elif current is not None:
            sections[current].append(words)
    return sections


def directive(lines, *prefix):
    return [w for w in lines if w[:len(prefix)] == list(prefix)]


def option_value(words, option):
    """The word after `option` in a directive or argv, or None."""
    if option in words and words.index(option) + 1 < len(words):
        return words[words.index(option) + 1]
    return None


# ---------------------------------------------------------------------------
# The checks. Each takes an Overlay and returns a list of errors.


class Overlay:
    def __init__(self, name, resources, help_flags, entrypoint):
        self.name = name
        self.resources = resources
        self.flag_names, self.bool_flags = help_flags
        servers = [r for r in workloads(resources)
                   if any(is_server(c) for c in pod_spec(r.doc).get("containers") or [])]
        self.server = Server(resources, servers[0], self.bool_flags, entrypoint) \
            if len(servers) == 1 else None
        self.server_count = len(servers)
        self.proxies = [r for r in workloads(resources)
                        if any(is_haproxy(c) for c in pod_spec(r.doc).get("containers") or [])]


def is_haproxy(container):
    return "haproxy" in image_name(container.get("image")) or \
        (container.get("command") or [""])[0].endswith("haproxy")


def need_server(ov):
    if ov.server is None:
        return [f"{ov.name}: {ov.server_count} workloads run a container {SERVER}, want 1"]
    return []


def check_documents(ov):
    errors, seen = [], set()
    for r in ov.resources:
        d = r.doc
        if not isinstance(d, dict):
            errors.append(f"{r.origin}: a document that is not a mapping")
            continue
        for field in ("apiVersion", "kind"):
            if not isinstance(d.get(field), str) or not d.get(field):
                errors.append(f"{r.where()}: no {field}")
        if not isinstance(d.get("metadata"), dict) or not (d["metadata"].get("name")):
            errors.append(f"{r.where()}: no metadata.name")
        key = (d.get("kind"), (d.get("metadata") or {}).get("name"))
        if key in seen:
            errors.append(f"{r.where()}: a second {key[0]} named {key[1]}")
        seen.add(key)
    return errors


def check_flags(ov):
    errors = need_server(ov)
    if errors:
        return errors
    s = ov.server
    errors += s.errors
    for name, value, where in s.flags:
        known = name in ov.flag_names or (
            name.startswith("no") and name[2:] in ov.bool_flags and value is None)
        if not known:
            errors.append(f"{where}: --{name} is not a flag of oaipp-server (--helpfull)")
        elif name in ov.bool_flags and value not in (None, "true", "false", "1", "0"):
            errors.append(f"{where}: --{name}={value}: a bool flag takes true or false")
    return errors


def check_files(ov):
    errors = need_server(ov)
    if errors:
        return errors
    s = ov.server
    for name, value, where in s.flags:
        if name in FILE_FLAGS and value:
            kind, desc, content, error = resolve_path(ov.resources, s.spec, s.container, value)
            if error:
                errors.append(f"{where}: --{name}={value}: {error}")
            elif kind not in ("configMap", "secret"):
                errors.append(f"{where}: --{name}={value} is on {desc}, not on a Secret or "
                              "ConfigMap")
    if s.get("store") == "sqlite":
        data_dir = s.get("data_dir")
        kind, desc, _, error = resolve_path(ov.resources, s.spec, s.container,
                                            data_dir.rstrip("/") + "/missions.db")
        if error or kind != "claim":
            errors.append(f"{ov.name}: --data_dir={data_dir} (the sqlite store) is on "
                          f"{desc or 'the root filesystem'}, not on a PersistentVolumeClaim: "
                          "the missions would not outlive the pod")
        elif find(ov.resources, "PersistentVolumeClaim", desc.split("/", 1)[1]) is None:
            errors.append(f"{ov.name}: {desc} (--data_dir) is not in the manifests")
    return errors


def container_port(container, name_or_number):
    for p in container.get("ports") or []:
        if name_or_number in (p.get("name"), p.get("containerPort")):
            return p.get("containerPort")
    return None


def check_ports(ov):
    errors = need_server(ov)
    if errors:
        return errors
    s = ov.server
    where = f"{s.res.where()} containers[{s.container.get('name')}].ports"
    for flag, port_name in (("listen", "grpc"), ("metrics_listen", "metrics")):
        address = s.get(flag)
        if not address:
            errors.append(f"{ov.name}: --{flag} is empty")
            continue
        host, port = host_port(address)
        if is_loopback(host):
            errors.append(f"{ov.name}: --{flag}={address} is loopback: no probe, Service or "
                          "scraper can reach it")
        got = container_port(s.container, port_name)
        if got != port:
            errors.append(f"{where}: the port named {port_name} is {got}, but --{flag}={address}")
    annotations = (((s.doc.get("spec") or {}).get("template") or {}).get("metadata") or {}) \
        .get("annotations") or {}
    _, metrics_port = host_port(s.get("metrics_listen") or ":")
    if annotations.get("prometheus.io/scrape") != "true":
        errors.append(f"{s.res.where()} spec.template.metadata.annotations: prometheus.io/scrape "
                      "is not \"true\"")
    if str(annotations.get("prometheus.io/port")) != str(metrics_port):
        errors.append(f"{s.res.where()} spec.template.metadata.annotations: prometheus.io/port is "
                      f"{annotations.get('prometheus.io/port')}, but --metrics_listen="
                      f"{s.get('metrics_listen')}")
    return errors


def tls_on(server):
    return bool(server.values.get("tls_cert"))


def check_probes(ov):
    errors = need_server(ov)
    if errors:
        return errors
    s = ov.server
    _, port = host_port(s.get("listen"))
    tls = tls_on(s)
    for probe in ("startupProbe", "livenessProbe", "readinessProbe"):
        where = f"{s.res.where()} containers[{s.container.get('name')}].{probe}"
        p = s.container.get(probe)
        if not p:
            errors.append(f"{where}: missing")
            continue
        handlers = [h for h in ("grpc", "tcpSocket", "httpGet", "exec") if h in p]
        if tls:
            # The kubelet's gRPC probe dials in plaintext: against a TLS port
            # it would fail every time and the pod would never become ready.
            if handlers != ["tcpSocket"]:
                errors.append(f"{where}: {'/'.join(handlers) or 'no handler'} with --tls_cert on "
                              "the probed port; the kubelet's grpc probe has no TLS, so only "
                              "tcpSocket can see this server")
                continue
            got = container_port(s.container, p["tcpSocket"].get("port"))
        else:
            if handlers != ["grpc"]:
                errors.append(f"{where}: {'/'.join(handlers) or 'no handler'}, want a native grpc "
                              "probe (grpc.health.v1)")
                continue
            got = p["grpc"].get("port")
            service = p["grpc"].get("service", "")
            if probe == "readinessProbe" and service not in ("", MISSION_SERVICE):
                errors.append(f"{where}.grpc.service: {service!r} is not a service the server "
                              f"reports ('' or {MISSION_SERVICE})")
            if probe != "readinessProbe" and service:
                errors.append(f"{where}.grpc.service: {service!r}; it turns NOT_SERVING under "
                              "load, which must not restart the pod; use the overall status ''")
        if got != port:
            errors.append(f"{where}: port {got}, but --listen={s.get('listen')}")
    return errors


def check_resources(ov):
    errors = need_server(ov)
    if errors:
        return errors
    s = ov.server
    where = f"{s.res.where()} containers[{s.container.get('name')}].resources"
    if "max_missions" not in s.values:
        return [f"{ov.name}: --max_missions is not set; the memory limit follows from it"]
    try:
        missions = int(s.get("max_missions"))
        budget = int(s.get("max_memory_mb"))
        threads = int(s.get("planning_threads"))
    except ValueError as e:
        return [f"{ov.name}: {e}"]
    want_budget = missions * MISSION_MIB
    want_limit = want_budget + PROCESS_MIB
    if budget != want_budget:
        errors.append(f"{ov.name}: --max_memory_mb={budget}, want --max_missions x {MISSION_MIB} = "
                      f"{missions} x {MISSION_MIB} = {want_budget}")
    res = s.container.get("resources") or {}
    for part in ("limits", "requests"):
        got = mib((res.get(part) or {}).get("memory"))
        if got is None or abs(got - want_limit) > 0.5:
            errors.append(f"{where}.{part}.memory: {(res.get(part) or {}).get('memory')}, want "
                          f"{missions} x {MISSION_MIB} + {PROCESS_MIB} = {want_limit}Mi")
    cpu = cpu_cores((res.get("requests") or {}).get("cpu"))
    if cpu is None or cpu < threads:
        errors.append(f"{where}.requests.cpu: {(res.get('requests') or {}).get('cpu')}, want at "
                      f"least --planning_threads={threads} cores")
    cpu_limit = (res.get("limits") or {}).get("cpu")
    if cpu_limit is not None and cpu is not None and (cpu_cores(cpu_limit) or 0) < cpu:
        errors.append(f"{where}.limits.cpu: {cpu_limit} is below the request")
    return errors


def check_shutdown(ov):
    errors = need_server(ov)
    if errors:
        return errors
    s = ov.server
    grace = s.spec.get("terminationGracePeriodSeconds", 30)
    try:
        drain = float(s.get("shutdown_grace_s"))
    except ValueError:
        return [f"{ov.name}: --shutdown_grace_s={s.get('shutdown_grace_s')} is not a number"]
    if not grace > drain:
        errors.append(f"{s.res.where()} spec.template.spec.terminationGracePeriodSeconds: {grace}, "
                      f"want more than --shutdown_grace_s={s.get('shutdown_grace_s')} (the "
                      "kubelet's SIGKILL would cut the drain and the last snapshots)")
    return errors


def check_security(ov):
    errors = []
    for r in workloads(ov.resources):
        spec = pod_spec(r.doc)
        pod_ctx = spec.get("securityContext") or {}
        for c in (spec.get("containers") or []) + (spec.get("initContainers") or []):
            where = f"{r.where()} containers[{c.get('name')}].securityContext"
            ctx = c.get("securityContext") or {}
            non_root = ctx.get("runAsNonRoot", pod_ctx.get("runAsNonRoot"))
            user = ctx.get("runAsUser", pod_ctx.get("runAsUser"))
            if non_root is not True:
                errors.append(f"{where}.runAsNonRoot: {non_root}, want true")
            if user is not None and int(user) == 0:
                errors.append(f"{where}.runAsUser: 0")
            if is_server(c) and user not in (None, 10001):
                errors.append(f"{where}.runAsUser: {user}; the image's user is 10001")
            if ctx.get("readOnlyRootFilesystem") is not True:
                errors.append(f"{where}.readOnlyRootFilesystem: {ctx.get('readOnlyRootFilesystem')}"
                              ", want true")
            if ctx.get("allowPrivilegeEscalation") is not False:
                errors.append(f"{where}.allowPrivilegeEscalation: "
                              f"{ctx.get('allowPrivilegeEscalation')}, want false")
            if "ALL" not in ((ctx.get("capabilities") or {}).get("drop") or []):
                errors.append(f"{where}.capabilities.drop: no ALL")
            if (ctx.get("capabilities") or {}).get("add"):
                errors.append(f"{where}.capabilities.add: {ctx['capabilities']['add']}")
    return errors


def check_tenants(ov):
    """Quotas keep one tenant from taking every mission slot or the whole
    planning queue (a full queue turns the replica NOT_SERVING and moves
    missions for every tenant), and reflection is off."""
    errors = need_server(ov)
    if errors:
        return errors
    s = ov.server
    if s.get("reflection") not in ("false", "0"):
        errors.append(f"--reflection={s.get('reflection')}: a deployed server does not "
                      "describe its API to whoever asks (--reflection=false)")
    missions = int(s.get("max_missions"))
    per_tenant = int(s.get("max_missions_per_tenant"))
    if not 1 <= per_tenant < missions:
        errors.append(f"--max_missions_per_tenant={per_tenant}: want 1 .. {missions - 1} "
                      f"(below --max_missions={missions})")
    queue = int(s.get("planning_queue"))
    plans = int(s.get("max_plans_per_tenant"))
    if not 1 <= plans < queue:
        errors.append(f"--max_plans_per_tenant={plans}: want 1 .. {queue - 1} "
                      f"(below --planning_queue={queue})")
    return errors


def selects(selector, labels):
    return bool(selector) and all(labels.get(k) == v for k, v in selector.items())


def check_pdb(ov):
    errors = need_server(ov)
    if errors:
        return errors
    pdbs = [r for r in ov.resources if r.doc.get("kind") == "PodDisruptionBudget"]
    if not any(selects(((r.doc.get("spec") or {}).get("selector") or {}).get("matchLabels"),
                       pod_labels(ov.server.doc)) for r in pdbs):
        errors.append(f"{ov.name}: no PodDisruptionBudget selects the pods of "
                      f"{ov.server.res.where()} (labels {pod_labels(ov.server.doc)})")
    for r in pdbs:
        spec = r.doc.get("spec") or {}
        selector = (spec.get("selector") or {}).get("matchLabels")
        if (spec.get("selector") or {}).get("matchExpressions"):
            errors.append(f"{r.where()} spec.selector.matchExpressions: not checked; use "
                          "matchLabels")
        if not any(selects(selector, pod_labels(w.doc)) for w in workloads(ov.resources)):
            errors.append(f"{r.where()} spec.selector.matchLabels {selector} selects no pods")
        if "minAvailable" in spec and "maxUnavailable" in spec:
            errors.append(f"{r.where()} spec: both minAvailable and maxUnavailable")
    return errors


def check_services(ov):
    errors = []
    for r in ov.resources:
        if r.doc.get("kind") != "Service":
            continue
        spec = r.doc.get("spec") or {}
        selector = spec.get("selector")
        targets = [w for w in workloads(ov.resources) if selects(selector, pod_labels(w.doc))]
        if not targets:
            errors.append(f"{r.where()} spec.selector {selector} matches the pods of no workload")
            continue
        for n, port in enumerate(spec.get("ports") or []):
            target = port.get("targetPort", port.get("port"))
            for w in targets:
                containers = pod_spec(w.doc).get("containers") or []
                if not any(container_port(c, target) is not None for c in containers):
                    errors.append(f"{r.where()} spec.ports[{n}].targetPort {target!r} is no "
                                  f"container port of {w.where()}")
    return errors


def referenced_objects(spec):
    """(kind, name, key or None, where) of every ConfigMap, Secret and claim a
    pod spec names."""
    refs = []
    for v in spec.get("volumes") or []:
        where = f"volumes[{v.get('name')}]"
        if "secret" in v:
            keys = [i.get("key") for i in v["secret"].get("items") or []] or [None]
            refs += [("Secret", v["secret"].get("secretName"), k, where) for k in keys]
        if "configMap" in v:
            keys = [i.get("key") for i in v["configMap"].get("items") or []] or [None]
            refs += [("ConfigMap", v["configMap"].get("name"), k, where) for k in keys]
        if "persistentVolumeClaim" in v:
            refs.append(("PersistentVolumeClaim", v["persistentVolumeClaim"].get("claimName"),
                         None, where))
    for c in (spec.get("containers") or []) + (spec.get("initContainers") or []):
        for e in c.get("env") or []:
            ref = e.get("valueFrom") or {}
            where = f"containers[{c.get('name')}].env[{e.get('name')}]"
            if "secretKeyRef" in ref:
                key_ref = ref["secretKeyRef"]
                refs.append(("Secret", key_ref.get("name"), key_ref.get("key"), where))
            if "configMapKeyRef" in ref:
                refs.append(("ConfigMap", ref["configMapKeyRef"].get("name"),
                             ref["configMapKeyRef"].get("key"), where))
        for e in c.get("envFrom") or []:
            for kind, field in (("Secret", "secretRef"), ("ConfigMap", "configMapRef")):
                if field in e:
                    refs.append((kind, e[field].get("name"), None,
                                 f"containers[{c.get('name')}].envFrom"))
    return refs


def check_secrets(ov):
    errors = []
    for w in workloads(ov.resources):
        for kind, name, key, where in referenced_objects(pod_spec(w.doc)):
            r = find(ov.resources, kind, name)
            if r is None:
                errors.append(f"{w.where()} spec.template.spec.{where}: {kind}/{name} is not in "
                              "the manifests")
                continue
            if key is not None:
                data = secret_values(r.doc) if kind == "Secret" else (r.doc.get("data") or {})
                if key not in data:
                    errors.append(f"{w.where()} spec.template.spec.{where}: {r.where()} has no key "
                                  f"{key!r}")
    for r in ov.resources:
        if r.doc.get("kind") != "Secret":
            continue
        for key, value in secret_values(r.doc).items():
            if "REPLACE-ME" not in value:
                errors.append(f"{r.where()} {key}: holds a value, not a REPLACE-ME placeholder; "
                              "real secrets do not belong in the repository")
    return errors


def check_transport(ov):
    errors = need_server(ov)
    if errors:
        return errors
    s = ov.server
    cert, key = s.values.get("tls_cert"), s.values.get("tls_key")
    if bool(cert) != bool(key):
        errors.append(f"{ov.name}: --tls_cert and --tls_key go together")
    if s.values.get("tls_client_ca") and not cert:
        errors.append(f"{ov.name}: --tls_client_ca without --tls_cert")
    host, port = host_port(s.get("listen"))
    if is_loopback(host) or cert:
        return errors
    if not s.bool("allow_insecure_remote"):
        errors.append(f"{ov.name}: --listen={s.get('listen')} without TLS and without "
                      "--allow_insecure_remote: the server refuses to start")
        return errors
    # Plaintext on the pod network: only a NetworkPolicy keeps others off it.
    guarded = False
    for r in ov.resources:
        if r.doc.get("kind") != "NetworkPolicy":
            continue
        spec = r.doc.get("spec") or {}
        if not selects((spec.get("podSelector") or {}).get("matchLabels"), pod_labels(s.doc)):
            continue
        if "Ingress" not in (spec.get("policyTypes") or ["Ingress"]):
            continue
        open_rules = [rule for rule in spec.get("ingress") or []
                      if not rule.get("from") and (not rule.get("ports") or any(
                          p.get("port") in (port, "grpc") for p in rule.get("ports")))]
        if not open_rules:
            guarded = True
    if not guarded:
        errors.append(f"{ov.name}: plaintext --listen={s.get('listen')} "
                      "(--allow_insecure_remote) and no NetworkPolicy limits who reaches it")
    return errors


def replicas(res):
    return (res.doc.get("spec") or {}).get("replicas", 1)


def check_store(ov):
    errors = need_server(ov)
    if errors:
        return errors
    s = ov.server
    store = s.get("store") or ""
    if store == "sqlite":
        if replicas(s.res) != 1:
            errors.append(f"{s.res.where()} spec.replicas: {replicas(s.res)} on one sqlite file")
        strategy = ((s.doc.get("spec") or {}).get("strategy") or {}).get("type", "RollingUpdate")
        if s.doc.get("kind") == "Deployment" and strategy != "Recreate":
            errors.append(f"{s.res.where()} spec.strategy.type: {strategy}; a rolling update "
                          "runs two servers on the sqlite file at once, want Recreate")
    elif store.startswith(("postgresql://", "postgres://")):
        source = s.env_sources.get("store")
        secret = source is not None and "secretKeyRef" in (source.get("valueFrom") or {})
        if not secret:
            errors.append(f"{ov.name}: --store=postgresql://... does not come from a Secret "
                          "(through --fromenv=store or --store=$(VAR) with a secretKeyRef): its "
                          "password would sit in a ConfigMap or the pod spec")
    elif store == "memory":
        errors.append(f"{ov.name}: --store=memory loses every mission when the pod restarts")
    else:
        errors.append(f"{ov.name}: --store={store!r} is neither sqlite nor a PostgreSQL URL")
    return errors


def headless_services_of(ov, labels):
    return [r for r in ov.resources if r.doc.get("kind") == "Service"
            and (r.doc.get("spec") or {}).get("clusterIP") == "None"
            and selects((r.doc.get("spec") or {}).get("selector"), labels)]


def check_cluster(ov):
    errors = need_server(ov)
    if errors:
        return errors
    s = ov.server
    cluster = s.bool("cluster")
    store = s.get("store") or ""
    if ov.name == "cluster" and not cluster:
        errors.append(f"{ov.name}: the server runs without --cluster")
    if ov.name == "single" and (cluster or replicas(s.res) != 1 or ov.proxies):
        errors.append(f"{ov.name}: want one replica, no --cluster and no proxy")
    if not cluster:
        if replicas(s.res) != 1:
            errors.append(f"{s.res.where()} spec.replicas: {replicas(s.res)} without --cluster: "
                          "every replica would load and write every mission")
        return errors
    if not store.startswith(("postgresql://", "postgres://")):
        errors.append(f"{ov.name}: --cluster with --store={store!r}; the replicas must share "
                      "PostgreSQL (the server refuses to start)")
    if replicas(s.res) < 2:
        errors.append(f"{s.res.where()} spec.replicas: {replicas(s.res)} with --cluster")
    if not ov.proxies:
        errors.append(f"{ov.name}: --cluster without a proxy routing by {MISSION_HEADER}")
    if not headless_services_of(ov, pod_labels(s.doc)):
        errors.append(f"{ov.name}: no headless Service (clusterIP: None) selects the replicas, so "
                      "the proxy cannot see each of them")
    for r in ov.resources:
        spec = r.doc.get("spec") or {}
        if r.doc.get("kind") == "Service" and spec.get("clusterIP") != "None" \
                and selects(spec.get("selector"), pod_labels(s.doc)):
            errors.append(f"{r.where()} spec.selector: a load-balanced Service straight to the "
                          "replicas bypasses the proxy's hash (replicas would take missions from "
                          "each other)")
    return errors


def check_server_line(ov, cfg, sv, options, host, swhere, ids):
    """A proxy's `server` line: a fixed id, and a name that stays the same
    replica's (a StatefulSet pod's DNS name under its headless Service)."""
    errors = []
    sid = option_value(sv[3:], "id")
    if sid is None:
        errors.append(f"{swhere}: no id: HAProxy numbers servers in the order of the file, so "
                      "proxies that list them in another order disagree on the hash ring")
    elif sid in ids:
        errors.append(f"{swhere}: id {sid} is also {ids[sid]}'s")
    else:
        ids[sid] = sv[1]
    if re.fullmatch(r"[0-9.]+|\[[0-9a-fA-F:]*\]", host or ""):
        return errors  # an address: the same replica for every proxy
    resolvers = option_value(options, "resolvers")
    if resolvers is None or ("resolvers", resolvers) not in cfg:
        errors.append(f"{swhere}: resolvers {resolvers!r} is not defined")
    labels = (host or "").split(".")
    pod, service = labels[0], labels[1] if len(labels) > 1 else ""
    s = ov.server
    sts = (s.doc.get("metadata") or {}).get("name") if s else None
    if s is None or s.doc.get("kind") != "StatefulSet":
        errors.append(f"{swhere}: {host} names a pod, but the replicas are a "
                      f"{s.doc.get('kind') if s else 'missing workload'}, whose pods have no "
                      "stable names")
        return errors
    if not re.fullmatch(rf"{re.escape(sts)}-[0-9]+", pod):
        errors.append(f"{swhere}: {pod} is not a pod of the StatefulSet {sts}")
    elif s.bool("ring_id_from_ordinal") and sid is not None and sid != str(int(pod.rsplit("-", 1)[1]) + 1):
        errors.append(f"{swhere}: id {sid}, but {pod} stands by as ring id "
                      f"{int(pod.rsplit('-', 1)[1]) + 1} (--ring_id_from_ordinal: its ordinal "
                      "plus one)")
    if (s.doc.get("spec") or {}).get("serviceName") != service:
        errors.append(f"{swhere}: {service} is not the StatefulSet's serviceName, so {host} "
                      "does not resolve")
    r = find(ov.resources, "Service", service)
    if r is None or (r.doc.get("spec") or {}).get("clusterIP") != "None" or \
            not selects((r.doc.get("spec") or {}).get("selector"), pod_labels(s.doc)):
        errors.append(f"{swhere}: {service} is not a headless Service selecting the replicas")
    return errors


def check_proxy(ov):
    errors = []
    for w in ov.proxies:
        spec = pod_spec(w.doc)
        c = next(c for c in spec.get("containers") or [] if is_haproxy(c))
        argv = [str(a) for a in (c.get("command") or []) + (c.get("args") or [])]
        cfg_path = option_value(argv, "-f")
        where = f"{w.where()} containers[{c.get('name')}]"
        if cfg_path is None:
            errors.append(f"{where}: no -f <haproxy.cfg> in command/args")
            continue
        kind, desc, text, error = resolve_path(ov.resources, spec, c, cfg_path)
        if error or text is None:
            errors.append(f"{where}: -f {cfg_path}: {error or 'not a ConfigMap file'}")
            continue
        cfg = parse_haproxy(text)
        env = {e.get("name") for e in c.get("env") or []}
        for var in sorted(set(re.findall(r"\$\{([A-Za-z_][A-Za-z0-9_]*)\}", text)) - env):
            errors.append(f"{desc}: ${{{var}}} is no env var of {where}")
        defaults = [lines for (sec, _), lines in cfg.items() if sec == "defaults"]
        mode = {sec: next((w_[1] for w_ in lines if w_[0] == "mode"), None)
                for sec, lines in cfg.items()}
        default_mode = next((w_[1] for lines in defaults for w_ in lines if w_[0] == "mode"), "tcp")
        grpc_port = container_port(c, "grpc")
        frontends = [(name, lines) for (sec, name), lines in cfg.items() if sec == "frontend"]
        front = None
        for name, lines in frontends:
            for b in directive(lines, "bind"):
                _, port = host_port(b[1])
                if port == grpc_port:
                    front = (name, lines, b)
        if front is None:
            errors.append(f"{desc}: no frontend binds the container port named grpc ({grpc_port})")
            continue
        fname, flines, bind = front
        fwhere = f"{desc} frontend {fname}"
        if (mode.get(("frontend", fname)) or default_mode) != "http":
            errors.append(f"{fwhere}: mode is not http; routing by a header needs it")
        if option_value(bind, "proto") != "h2":
            errors.append(f"{fwhere}: bind {' '.join(bind[1:])}: no proto h2")
        if "ssl" in bind:
            if "h2" not in (option_value(bind, "alpn") or "").split(","):
                errors.append(f"{fwhere}: bind ... ssl without alpn h2 (gRPC clients require it)")
            # The key is in the certificate's file or, as HAProxy looks for
            # it, in <crt>.key beside it.
            crt = option_value(bind, "crt") or ""
            _, _, content, error = resolve_path(ov.resources, spec, c, crt)
            if error:
                errors.append(f"{fwhere}: bind crt: {error}")
            elif "PRIVATE KEY" not in str(content):
                _, _, _, error = resolve_path(ov.resources, spec, c, crt + ".key")
                if error:
                    errors.append(f"{fwhere}: bind crt: the key: {error}")
        backend_name = next((w_[1] for w_ in flines if w_[0] in ("default_backend", "use_backend")),
                            None)
        blines = cfg.get(("backend", backend_name))
        if blines is None:
            errors.append(f"{fwhere}: default_backend {backend_name!r} is not defined")
            continue
        bwhere = f"{desc} backend {backend_name}"
        if (mode.get(("backend", backend_name)) or default_mode) != "http":
            errors.append(f"{bwhere}: mode is not http")
        # What the backend inherits from defaults counts, the last word wins.
        inherited = [w_ for lines in defaults for w_ in lines] + blines
        balance = [w_ for w_ in inherited if w_[0] == "balance"]
        if not balance or balance[-1] != ["balance", f"hdr({MISSION_HEADER})"]:
            errors.append(f"{bwhere}: no 'balance hdr({MISSION_HEADER})'")
        hash_type = [w_ for w_ in inherited if w_[0] == "hash-type"]
        if not hash_type or hash_type[-1][1:2] != ["consistent"]:
            errors.append(f"{bwhere}: no 'hash-type consistent' (a replica leaving would move "
                          "every mission)")
        standbys = ov.server is not None and (ov.server.bool("ring_id_from_ordinal") or
                                              str(ov.server.get("ring_id") or "0") != "0")
        redispatch = ["option", "redispatch"] in [w_[:2] for w_ in inherited]
        if standbys and redispatch:
            errors.append(f"{bwhere}: 'option redispatch' with replicas on warm standby: a call "
                          "a dead replica refuses would go to whichever server follows on the "
                          "ring, not always the one standing by for its mission")
        if not standbys and not redispatch:
            errors.append(f"{bwhere}: no 'option redispatch'")
        default_server = [word for w_ in inherited if w_[0] == "default-server" for word in w_[1:]]
        servers = directive(blines, "server") + directive(blines, "server-template")
        if not servers:
            errors.append(f"{bwhere}: no server or server-template")
        listen_port = host_port(ov.server.get("listen"))[1] if ov.server else None
        running = sum(replicas(p) for p in ov.proxies)
        ids = {}
        for sv in servers:
            template = sv[0] == "server-template"
            address = sv[3] if template else sv[2]
            swhere = f"{bwhere} {sv[0]} {sv[1]}"
            options = default_server + sv[3 if not template else 4:]
            if option_value(options, "proto") != "h2":
                errors.append(f"{swhere}: no proto h2 (the replicas speak HTTP/2 only)")
            if "check" not in options or "no-check" in sv:
                errors.append(f"{swhere}: no check")
            host, port = host_port(address)
            if port != listen_port:
                errors.append(f"{swhere}: port {port}, but the server's --listen port is "
                              f"{listen_port}")
            if template and running > 1:
                errors.append(f"{swhere}: {running} proxies with a server-template: each numbers "
                              "its slots in the order its DNS answers come, so they disagree on "
                              "the hash ring and route a mission to different replicas; list the "
                              "StatefulSet's pods, one server line each with a fixed id")
            if not template:
                errors.extend(check_server_line(ov, cfg, sv, options, host, swhere, ids))
            if template:
                resolvers = option_value(sv, "resolvers")
                if resolvers is None or ("resolvers", resolvers) not in cfg:
                    errors.append(f"{swhere}: resolvers {resolvers!r} is not defined")
                service = host.split(".")[0]
                r = find(ov.resources, "Service", service)
                if r is None or (r.doc.get("spec") or {}).get("clusterIP") != "None":
                    errors.append(f"{swhere}: {host} is not a headless Service of the manifests "
                                  "(a ClusterIP name resolves to one address: one server)")
                elif ov.server and not selects((r.doc.get("spec") or {}).get("selector"),
                                               pod_labels(ov.server.doc)):
                    errors.append(f"{swhere}: {r.where()} does not select the server's pods")
        fronting = [r for r in ov.resources if r.doc.get("kind") == "Service"
                    and selects((r.doc.get("spec") or {}).get("selector"), pod_labels(w.doc))]
        if not fronting:
            errors.append(f"{w.where()}: no Service selects the proxy's pods")
    return errors


CHECKS = [
    ("documents", "every document has apiVersion, kind and metadata.name", check_documents),
    ("flags", "every flag (args, flag files, --fromenv) is one oaipp-server knows", check_flags),
    ("files", "files the flags name are on mounted ConfigMaps, Secrets or claims", check_files),
    ("ports", "container ports and Prometheus annotations match --listen/--metrics_listen",
     check_ports),
    ("probes", "startup/liveness/readiness probe the --listen port (grpc, or TCP under TLS)",
     check_probes),
    ("resources", f"memory = max_missions x {MISSION_MIB} MiB + {PROCESS_MIB} MiB; CPU >= "
     "planning threads", check_resources),
    ("shutdown", "terminationGracePeriodSeconds > --shutdown_grace_s", check_shutdown),
    ("security", "non-root, read-only root, no privilege escalation, capabilities dropped",
     check_security),
    ("tenants", "tenant quotas below the server's limits, reflection off", check_tenants),
    ("pdb", "a PodDisruptionBudget selects the server's pods", check_pdb),
    ("services", "Service selectors and target ports match pods", check_services),
    ("secrets", "Secrets, ConfigMaps and claims referenced exist (Secrets as placeholders)",
     check_secrets),
    ("transport", "TLS, or plaintext fenced by a NetworkPolicy", check_transport),
    ("store", "the store fits the replicas, PostgreSQL's URL from a Secret", check_store),
    ("cluster", "--cluster: PostgreSQL, replicas, proxy and headless Service", check_cluster),
    ("proxy", f"HAProxy: h2, balance hdr({MISSION_HEADER}), hash-type consistent, checks",
     check_proxy),
]


def run_checks(ov, only=None):
    """{check name: errors} for one overlay."""
    results = {}
    for name, _, fn in CHECKS:
        if only and name not in only:
            continue
        try:
            results[name] = fn(ov)
        except Exception as e:  # a malformed manifest must fail, not crash the run
            results[name] = [f"{ov.name}: {type(e).__name__}: {e}"]
    return results


def overlay_dirs(root):
    names = sorted(n for n in os.listdir(root)
                   if n != "base" and os.path.isfile(os.path.join(root, n, "kustomization.yaml")))
    return names


class Report:
    def __init__(self):
        self.passed = self.failed = self.skipped = 0

    def ok(self, text):
        self.passed += 1
        print(f"ok    {text}")

    def fail(self, text, errors):
        self.failed += 1
        print(f"FAIL  {text}")
        for e in errors:
            print(f"      {e}")

    def skip(self, text):
        self.skipped += 1
        print(f"skip  {text}")

    def close(self):
        tail = f", {self.skipped} skipped" if self.skipped else ""
        print(f"{self.passed} passed, {self.failed} failed{tail}")
        return 1 if self.failed else 0


def render_overlay(root, name, report, kubectl):
    """The overlay's Res, or None when it cannot be rendered."""
    folder = os.path.join(root, name)
    try:
        resources = render(folder, root)
    except (Unsupported, ValueError, KeyError, OSError, yaml.YAMLError) as e:
        report.fail(f"{name}: render", [f"{type(e).__name__}: {e}"])
        return None
    if kubectl[0] is None:
        report.skip(f"{name}: compare with kubectl kustomize ({kubectl[1]}); rendered with the "
                    "built-in subset only")
        return resources
    run = subprocess.run([kubectl[0], "kustomize", folder], capture_output=True, text=True,
                         timeout=120, check=False)
    if run.returncode != 0:
        report.fail(f"{name}: kubectl kustomize {kubectl[1]}", [run.stderr.strip()])
        return resources

    def keyed(docs):
        return {(d.get("kind"), (d.get("metadata") or {}).get("name")): canonical(d) for d in docs}

    mine = keyed([r.doc for r in resources])
    theirs = keyed([d for d in yaml.safe_load_all(run.stdout) if d is not None])
    diffs = [f"{k[0]}/{k[1]}: differs" for k in sorted(set(mine) | set(theirs), key=str)
             if mine.get(k) != theirs.get(k)]
    if diffs:
        report.fail(f"{name}: built-in rendering equals kubectl kustomize {kubectl[1]}", diffs)
    else:
        report.ok(f"{name}: built-in rendering equals kubectl kustomize {kubectl[1]}")
    return resources


def main_check(binary, root):
    report = Report()
    help_flags = parse_help(binary)
    print(f"oaipp-server knows {len(help_flags[0])} flags ({binary} --helpfull)")
    entrypoint = image_entrypoint(root)
    print(f"the image's ENTRYPOINT passes {' '.join(entrypoint) or 'no flags'} before the args")
    kubectl = kubectl_kustomize_version()
    names = overlay_dirs(root)
    for required in ("single", "cluster"):
        if required not in names:
            report.fail(f"{required}: overlay",
                        [f"{root}/{required}/kustomization.yaml is missing"])
    for name in names:
        resources = render_overlay(root, name, report, kubectl)
        if resources is None:
            continue
        ov = Overlay(name, resources, help_flags, entrypoint)
        results = run_checks(ov)
        for check, text, _ in CHECKS:
            if results[check]:
                report.fail(f"{name}: {check}: {text}", results[check])
            else:
                report.ok(f"{name}: {check}: {text}")
    return report.close()


# ---------------------------------------------------------------------------
# Self-test: every fault below must be caught by the check named with it.


def doc_of(resources, kind, name):
    r = find(resources, kind, name)
    if r is None:
        raise LookupError(f"{kind}/{name} is not in the rendering")
    return r.doc


def server_doc(resources):
    return next(r.doc for r in workloads(resources)
                if any(is_server(c) for c in pod_spec(r.doc).get("containers") or []))


def server_container(resources):
    return next(c for c in pod_spec(server_doc(resources))["containers"]
                if is_server(c))


def flags_configmap(resources):
    """The ConfigMap and key of the server's last flag file."""
    c = server_container(resources)
    path = next(a for a in c["args"] if a.startswith("--flagfile=")).split("=", 1)[1]
    path = path.split(",")[-1]
    for mount in c.get("volumeMounts") or []:
        if path.startswith(mount["mountPath"].rstrip("/") + "/"):
            volume = next(v for v in pod_spec(server_doc(resources))["volumes"]
                          if v["name"] == mount["name"])
            return doc_of(resources, "ConfigMap", volume["configMap"]["name"]), \
                path[len(mount["mountPath"].rstrip("/")) + 1:]
    raise LookupError("no flag file")


def set_flag(resources, name, value):
    """--name=value in place of --name in the flag files, or at the end of the
    last one."""
    cm, last = flags_configmap(resources)
    line = f"--{name}" if value is None else f"--{name}={value}"
    pattern = re.compile(rf"^--{re.escape(name)}(=.*)?$", re.M)
    hit = False
    for key, text in cm["data"].items():
        if pattern.search(text):
            cm["data"][key] = pattern.sub(line, text)
            hit = True
    if not hit:
        cm["data"][last] += line + "\n"


def drop_flag(resources, name):
    cm, _ = flags_configmap(resources)
    for key, text in cm["data"].items():
        cm["data"][key] = re.sub(rf"^--{re.escape(name)}(=.*)?\n", "", text, flags=re.M)


def append_line(resources, line):
    cm, last = flags_configmap(resources)
    cm["data"][last] += line + "\n"


def proxy_cfg(resources, fn):
    cm = doc_of(resources, "ConfigMap", "oaipp-proxy-config")
    cm["data"]["haproxy.cfg"] = fn(cm["data"]["haproxy.cfg"])


def probe(resources, which):
    return server_container(resources)[which]


def mutate_env_literal(resources):
    env = server_container(resources)["env"]
    for e in env:
        if e["name"] == "FLAGS_store":
            e.pop("valueFrom")
            e["value"] = "postgresql://oaipp:secret@db:5432/oaipp"


# (overlay, fault, check that must catch it, mutation)
FAULTS = [
    ("single", "a document without apiVersion", "documents",
     lambda rs: rs[0].doc.pop("apiVersion")),
    ("cluster", "two documents with one kind and name", "documents",
     lambda rs: rs.append(Res(copy.deepcopy(rs[0].doc), "self-test"))),
    ("single", "an unknown flag in a flag file", "flags",
     lambda rs: append_line(rs, "--no_such_flag=1")),
    ("cluster", "an unknown flag in args", "flags",
     lambda rs: server_container(rs)["args"].append("--planing_threads=4")),
    ("cluster", "a flag-file line without --", "flags",
     lambda rs: append_line(rs, "cluster")),
    ("cluster", "--fromenv of a variable the container lacks", "flags",
     lambda rs: server_container(rs).pop("env")),
    ("single", "--flagfile on a path no volume holds", "flags",
     lambda rs: server_container(rs)["args"].__setitem__(0, "--flagfile=/etc/oaipp/x.flags")),
    ("single", "--token_file not on the Secret's volume", "files",
     lambda rs: set_flag(rs, "token_file", "/etc/oaipp/tokens/token")),
    ("single", "--tls_cert on a Secret key that is not there", "files",
     lambda rs: set_flag(rs, "tls_cert", "/etc/oaipp/tls/cert.pem")),
    ("single", "the sqlite store on the read-only root", "files",
     lambda rs: set_flag(rs, "data_dir", "/var/lib/elsewhere")),
    ("single", "the metrics container port off --metrics_listen", "ports",
     lambda rs: server_container(rs)["ports"][1].__setitem__("containerPort", 9465)),
    ("cluster", "--listen moved off the container port", "ports",
     lambda rs: set_flag(rs, "listen", "0.0.0.0:50052")),
    ("cluster", "--listen on loopback", "ports",
     lambda rs: set_flag(rs, "listen", "127.0.0.1:50051")),
    ("single", "the Prometheus annotation's port", "ports",
     lambda rs: server_doc(rs)["spec"]["template"]["metadata"]["annotations"]
     .__setitem__("prometheus.io/port", "9090")),
    ("cluster", "a wrong readiness probe port", "probes",
     lambda rs: probe(rs, "readinessProbe")["grpc"].__setitem__("port", 50052)),
    ("cluster", "an HTTP liveness probe instead of grpc", "probes",
     lambda rs: server_container(rs).__setitem__(
         "livenessProbe", {"httpGet": {"path": "/", "port": 9464}})),
    ("cluster", "liveness on the service that reports overload", "probes",
     lambda rs: probe(rs, "livenessProbe")["grpc"].__setitem__("service", MISSION_SERVICE)),
    ("cluster", "no startup probe", "probes",
     lambda rs: server_container(rs).pop("startupProbe")),
    ("single", "a grpc probe on the TLS port", "probes",
     lambda rs: server_container(rs).__setitem__("startupProbe", {"grpc": {"port": 50051}})),
    ("single", "a memory limit 1 MiB off", "resources",
     lambda rs: server_container(rs)["resources"]["limits"].__setitem__("memory", "2667Mi")),
    ("cluster", "--max_missions changed, limits not", "resources",
     lambda rs: set_flag(rs, "max_missions", "40")),
    ("single", "--max_memory_mb off the arithmetic", "resources",
     lambda rs: set_flag(rs, "max_memory_mb", "4096")),
    ("cluster", "less CPU than planning threads", "resources",
     lambda rs: set_flag(rs, "planning_threads", "4")),
    ("single", "a grace period shorter than the drain", "shutdown",
     lambda rs: pod_spec(server_doc(rs)).__setitem__("terminationGracePeriodSeconds", 30)),
    ("cluster", "reflection left on", "tenants",
     lambda rs: set_flag(rs, "reflection", "true")),
    ("single", "no mission quota per tenant", "tenants",
     lambda rs: set_flag(rs, "max_missions_per_tenant", "0")),
    ("cluster", "one tenant may fill the planning queue", "tenants",
     lambda rs: set_flag(rs, "max_plans_per_tenant", "32")),
    ("single", "a writable root filesystem", "security",
     lambda rs: server_container(rs)["securityContext"].__setitem__(
         "readOnlyRootFilesystem", False)),
    ("cluster", "capabilities not dropped on the proxy", "security",
     lambda rs: pod_spec(doc_of(rs, "Deployment", "oaipp-proxy"))["containers"][0]
     ["securityContext"].pop("capabilities")),
    ("cluster", "runAsNonRoot removed", "security",
     lambda rs: pod_spec(server_doc(rs))["securityContext"].pop("runAsNonRoot")),
    ("single", "a PDB selecting other pods", "pdb",
     lambda rs: doc_of(rs, "PodDisruptionBudget", "oaipp-server")["spec"]["selector"]
     ["matchLabels"].__setitem__("app.kubernetes.io/name", "oaipp")),
    ("single", "a Service selecting no pods", "services",
     lambda rs: doc_of(rs, "Service", "oaipp")["spec"]["selector"]
     .__setitem__("app.kubernetes.io/name", "oaipp-srv")),
    ("cluster", "a Service targetPort no container has", "services",
     lambda rs: doc_of(rs, "Service", "oaipp-server-replicas")["spec"]["ports"][0]
     .__setitem__("targetPort", "grcp")),
    ("single", "the tokens Secret missing", "secrets",
     lambda rs: rs.remove(find(rs, "Secret", "oaipp-tokens"))),
    ("cluster", "a Secret key the env reads renamed", "secrets",
     lambda rs: doc_of(rs, "Secret", "oaipp-store")["stringData"].__setitem__(
         "uri", doc_of(rs, "Secret", "oaipp-store")["stringData"].pop("url"))),
    ("single", "a real value committed in a Secret", "secrets",
     lambda rs: doc_of(rs, "Secret", "oaipp-tokens")["stringData"].__setitem__(
         "tokens", "team-a " + "ab" * 32 + "\n")),
    ("cluster", "plaintext without --allow_insecure_remote", "transport",
     lambda rs: drop_flag(rs, "allow_insecure_remote")),
    ("cluster", "plaintext with no NetworkPolicy", "transport",
     lambda rs: rs.remove(find(rs, "NetworkPolicy", "oaipp-server"))),
    ("cluster", "a NetworkPolicy open to everyone on 50051", "transport",
     lambda rs: doc_of(rs, "NetworkPolicy", "oaipp-server")["spec"]["ingress"][0].pop("from")),
    ("single", "--tls_key without --tls_cert", "transport",
     lambda rs: drop_flag(rs, "tls_cert")),
    ("single", "a rolling update over the sqlite file", "store",
     lambda rs: server_doc(rs)["spec"].__setitem__("strategy", {"type": "RollingUpdate"})),
    ("cluster", "PostgreSQL's URL as a literal env value", "store", mutate_env_literal),
    ("single", "--store=memory", "store",
     lambda rs: set_flag(rs, "store", "memory")),
    ("cluster", "--cluster dropped", "cluster",
     lambda rs: drop_flag(rs, "cluster")),
    ("cluster", "--cluster on sqlite", "cluster",
     lambda rs: (drop_flag(rs, "fromenv"),
                 set_flag(rs, "store", "sqlite"))),
    ("cluster", "clients' Service straight to the replicas", "cluster",
     lambda rs: doc_of(rs, "Service", "oaipp")["spec"]["selector"].__setitem__(
         "app.kubernetes.io/name", "oaipp-server")),
    ("cluster", "one replica", "cluster",
     lambda rs: server_doc(rs)["spec"].__setitem__("replicas", 1)),
    ("single", "--cluster in single", "cluster",
     lambda rs: set_flag(rs, "cluster", None)),
    ("cluster", "round robin instead of the mission header", "proxy",
     lambda rs: proxy_cfg(rs, lambda t: t.replace(f"balance hdr({MISSION_HEADER})",
                                                  "balance roundrobin"))),
    ("cluster", "hash-type consistent dropped", "proxy",
     lambda rs: proxy_cfg(rs, lambda t: t.replace("hash-type consistent", "hash-type map-based"))),
    ("cluster", "proto h2 dropped from the servers", "proxy",
     lambda rs: proxy_cfg(rs, lambda t: t.replace("default-server proto h2", "default-server"))),
    ("cluster", "proto h2 dropped from the bind", "proxy",
     lambda rs: proxy_cfg(rs, lambda t: re.sub(r"(bind :50051.*) proto h2", r"\1", t))),
    ("cluster", "no health checks on the servers", "proxy",
     lambda rs: proxy_cfg(rs, lambda t: re.sub(r"(default-server .*) check\b", r"\1", t))),
    ("cluster", "option redispatch with replicas on standby", "proxy",
     lambda rs: proxy_cfg(rs, lambda t: t.replace("hash-type consistent",
                                                  "hash-type consistent\n        option redispatch"))),
    ("cluster", "a server line's id off its pod's ordinal + 1", "proxy",
     lambda rs: proxy_cfg(rs, lambda t: t.replace(":50051\" id 1", ":50051\" id 9"))),
    ("cluster", "servers named under a ClusterIP Service", "proxy",
     lambda rs: proxy_cfg(rs, lambda t: t.replace("oaipp-server-replicas.", "oaipp."))),
    ("cluster", "two proxies with a server-template", "proxy",
     lambda rs: proxy_cfg(rs, lambda t: re.sub(
         r"( *server replica-.*\n)+",
         "    server-template replica 8 "
         "oaipp-server-replicas.${POD_NAMESPACE}.svc.cluster.local:50051\n", t))),
    ("cluster", "server lines without ids", "proxy",
     lambda rs: proxy_cfg(rs, lambda t: re.sub(r" id [0-9]+\n", "\n", t))),
    ("cluster", "two server lines with one id", "proxy",
     lambda rs: proxy_cfg(rs, lambda t: t.replace(" id 2\n", " id 1\n"))),
    ("cluster", "the replicas as a Deployment (no stable pod names)", "proxy",
     lambda rs: server_doc(rs).__setitem__("kind", "Deployment")),
    ("cluster", "a resolvers section that is not there", "proxy",
     lambda rs: proxy_cfg(rs, lambda t: t.replace("resolvers kube-dns init",
                                                  "resolvers dns init"))),
    ("cluster", "the servers on another port than --listen", "proxy",
     lambda rs: proxy_cfg(rs, lambda t: t.replace("cluster.local:50051", "cluster.local:50052"))),
    ("cluster", "an env var the proxy does not set", "proxy",
     lambda rs: pod_spec(doc_of(rs, "Deployment", "oaipp-proxy"))["containers"][0].pop("env")),
]


def self_test_merge():
    """The renderer's merge rules on small cases."""
    env_a, env_b = {"name": "A", "value": "1"}, {"name": "B", "value": "2"}
    base = {"spec": {"a": 1, "probe": {"grpc": {"port": 1}, "period": 5},
                     "containers": [{"name": "x", "args": ["--a"], "env": [env_a]}]}}
    patch = {"spec": {"probe": {"grpc": None, "tcpSocket": {"port": 2}},
                      "containers": [{"name": "x", "args": ["--b"], "env": [env_b]},
                                     {"name": "y"}]}}
    out = strategic_merge(base, patch)
    want = {"spec": {"a": 1, "probe": {"tcpSocket": {"port": 2}, "period": 5},
                     "containers": [{"name": "x", "args": ["--b"], "env": [env_a, env_b]},
                                    {"name": "y"}]}}
    errors = [] if out == want else [f"strategic merge gave {out}, want {want}"]
    out = json6902({"a": {"b": [1, 2]}}, [{"op": "add", "path": "/a/b/-", "value": 3},
                                         {"op": "replace", "path": "/a/b/0", "value": 0},
                                         {"op": "remove", "path": "/a/b/1"}])
    if out != {"a": {"b": [0, 3]}}:
        errors.append(f"JSON 6902 gave {out}")
    try:
        strategic_merge({"a": [{"name": "x"}]}, {"a": {"$patch": "replace"}})
        errors.append("a $patch directive was not refused")
    except Unsupported:
        pass
    return errors


def main_self_test(binary, root):
    report = Report()
    help_flags = parse_help(binary)
    entrypoint = image_entrypoint(root)
    errors = self_test_merge()
    if errors:
        report.fail("renderer: strategic merge and JSON 6902 on small cases", errors)
    else:
        report.ok("renderer: strategic merge and JSON 6902 on small cases")
    rendered = {}
    for name in ("single", "cluster"):
        try:
            rendered[name] = render(os.path.join(root, name), root)
        except (Unsupported, ValueError, KeyError, OSError, yaml.YAMLError) as e:
            report.fail(f"{name}: render", [str(e)])
            return report.close()
        baseline = run_checks(Overlay(name, rendered[name], help_flags, entrypoint))
        failing = {k: v for k, v in baseline.items() if v}
        if failing:
            report.fail(f"{name}: the unbroken manifests pass (a fault is only meaningful "
                        "against a clean baseline)", [e for v in failing.values() for e in v])
            return report.close()
        report.ok(f"{name}: the unbroken manifests pass every check")
    for overlay, fault, check, mutate in FAULTS:
        resources = [Res(copy.deepcopy(r.doc), r.origin) for r in rendered[overlay]]
        for r, orig in zip(resources, rendered[overlay]):
            r.patches = list(orig.patches)
        label = f"{overlay}: {fault} -> {check}"
        before = [copy.deepcopy(r.doc) for r in resources]
        try:
            mutate(resources)
        except Exception as e:  # the fault no longer applies to the manifests
            report.fail(label, [f"cannot make the fault: {type(e).__name__}: {e}"])
            continue
        if [r.doc for r in resources] == before:
            report.fail(label, ["the fault changed nothing: the manifests no longer have what "
                                "it breaks; update FAULTS"])
            continue
        caught = run_checks(Overlay(overlay, resources, help_flags, entrypoint),
                            only=[check])[check]
        if caught:
            report.ok(f"{label}: {caught[0]}")
        else:
            report.fail(label, ["not caught"])
    return report.close()


def main(argv):
    args = argv[1:]
    self_test = "--self-test" in args
    args = [a for a in args if a != "--self-test"]
    if len(args) != 2:
        print(__doc__.strip(), file=sys.stderr)
        return 2
    binary, root = args
    if not os.access(binary, os.X_OK):
        print(f"{binary}: not an executable (build oaipp-server first)", file=sys.stderr)
        return 2
    root = os.path.abspath(root)
    try:
        return main_self_test(binary, root) if self_test else main_check(binary, root)
    except (RuntimeError, OSError, ValueError, subprocess.TimeoutExpired) as e:
        print(f"FAIL  {type(e).__name__}: {e}")
        return 1


if __name__ == "__main__":
    sys.exit(main(sys.argv))
