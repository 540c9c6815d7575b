"""deploy/'s YAML: yamllint (deploy/.yamllint, warnings count) on every
deploy/**/*.yaml, then structural checks of the compose and Kubernetes
files that a linter cannot see: resource limits, probes, PDB and Service
selectors that match the pods, the cluster compose file's PostgreSQL with a
healthcheck, two API servers and replicated workers, hardening everywhere,
and every infilld command line built only from known sub-commands and
flags (so a typo is caught here, not at 3 a.m.).  Each check is shown to
fire on a deliberately broken copy of the files.  Needs no binary."""
import copy
import glob
import os
import shutil
import subprocess
import sys
import tempfile

import yaml

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from svc import ROOT, check, run  # noqa: E402

DEPLOY = os.path.join(ROOT, "deploy")
INFILLD = "/usr/local/bin/infilld"
# Sub-commands and flags the deploy files may use, the flags each taking one value.
FLAGS = {
    "serve": {"--listen", "--db", "--store", "--data", "--workers"},
    "worker": {"--db", "--store", "--data", "--slots"},
}
HARDENING = "read_only: true, cap_drop [ALL], no-new-privileges:true, tmpfs /tmp"


def yaml_files(deploy):
    return sorted(glob.glob(os.path.join(deploy, "**", "*.yaml"), recursive=True) +
                  glob.glob(os.path.join(deploy, "**", "*.yml"), recursive=True))


def yamllint(deploy, config=None):
    """yamllint's problems (parsable lines, warnings included) and its status."""
    files = yaml_files(deploy)
    check(files, "no YAML files under %s" % deploy)
    check(shutil.which("yamllint"), "no yamllint on PATH (make deps: deploy/deps.sh installs it)")
    out = subprocess.run(["yamllint", "--strict", "-f", "parsable", "-c",
                          config or os.path.join(DEPLOY, ".yamllint"), *files],
                         capture_output=True, text=True, timeout=120)
    return out.returncode, (out.stdout + out.stderr).strip()


def load_all(path):
    with open(path) as f:
        return [d for d in yaml.safe_load_all(f) if d is not None]


def argv_problems(where, argv):
    """An infilld command line: a known sub-command, then FLAG VALUE pairs."""
    if not isinstance(argv, list) or not argv:
        return ["%s: command is not a list of arguments: %r" % (where, argv)]
    bad = ["%s: argument %r is not a string" % (where, a) for a in argv if not isinstance(a, str)]
    if bad:
        return bad
    sub, rest = argv[0], argv[1:]
    if sub not in FLAGS:
        return ["%s: unknown sub-command %r (known: %s)" % (where, sub, ", ".join(sorted(FLAGS)))]
    out = []
    i = 0
    while i < len(rest):
        a = rest[i]
        if a not in FLAGS[sub]:
            out.append("%s: %s: unknown flag %r (known: %s)" %
                       (where, sub, a, " ".join(sorted(FLAGS[sub]))))
            i += 2 if i + 1 < len(rest) and not rest[i + 1].startswith("--") else 1
            continue
        if i + 1 >= len(rest) or rest[i + 1].startswith("--"):
            out.append("%s: %s needs a value" % (where, a))
            i += 1
            continue
        i += 2
    seen = [a for a in rest if a.startswith("--")]
    out += ["%s: %s given twice" % (where, a) for a in sorted(set(seen)) if seen.count(a) > 1]
    return out


def usable(argv):
    """Whether a command line is clear enough to tell its role (the checks
    after the flag check go on with it)."""
    return isinstance(argv, list) and argv and all(isinstance(a, str) for a in argv) and \
        argv[0] in FLAGS


def flag(argv, name):
    """The value of FLAG in an infilld command line, or None."""
    for i, a in enumerate(argv[:-1]):
        if a == name:
            return argv[i + 1]
    return None


# ---------------------------------------------------------------- compose

def compose_problems(deploy):
    p = []
    path = os.path.join(deploy, "compose-cluster.yaml")
    if not os.path.exists(path):
        return ["compose-cluster.yaml missing"]
    doc = load_all(path)[0]
    services = doc.get("services") or {}
    named = set((doc.get("volumes") or {}).keys())

    def mounts(svc):
        """(source, target) of each short-syntax volume."""
        out = []
        for v in svc.get("volumes") or []:
            parts = v.split(":") if isinstance(v, str) else [v.get("source"), v.get("target")]
            out.append((parts[0], parts[1]) if len(parts) > 1 else (None, parts[0]))
        return out

    for name, svc in services.items():
        where = "compose-cluster.yaml: %s" % name
        if not (svc.get("read_only") is True and "ALL" in (svc.get("cap_drop") or []) and
                "no-new-privileges:true" in (svc.get("security_opt") or []) and
                "/tmp" in (svc.get("tmpfs") or [])):
            p.append("%s: lacks the hardening of compose.yaml (%s)" % (where, HARDENING))
        for src, dst in mounts(svc):
            if src and not src.startswith((".", "/")) and src not in named:
                p.append("%s: volume %r is not declared under volumes:" % (where, src))

    pg = [n for n, s in services.items() if str(s.get("image", "")).startswith("postgres:15")]
    if len(pg) != 1:
        p.append("compose-cluster.yaml: want one postgres:15 service, found %r" % pg)
    for n in pg:
        test = (services[n].get("healthcheck") or {}).get("test") or []
        if "pg_isready" not in " ".join(test if isinstance(test, list) else [test]):
            p.append("compose-cluster.yaml: %s: no pg_isready healthcheck" % n)
        if not any(src in named for src, dst in mounts(services[n])):
            p.append("compose-cluster.yaml: %s: its data is not on a named volume" % n)

    infilld = {n: s for n, s in services.items()
               if s.get("entrypoint") == [INFILLD] or s.get("image", "").startswith("infilld")}
    api, workers, stores = [], [], set()
    for n, s in infilld.items():
        where = "compose-cluster.yaml: %s" % n
        argv = s.get("command")
        p += argv_problems(where, argv)
        if not usable(argv):
            continue
        if argv[0] == "serve":
            api.append(n)
            if flag(argv, "--workers") != "0":
                p.append("%s: an API server wants --workers 0" % where)
        else:
            replicas = (s.get("deploy") or {}).get("replicas", 1)
            if not isinstance(replicas, int) or replicas < 2:
                p.append("%s: worker deploy.replicas %r, want >= 2" % (where, replicas))
            workers.append(n)
        env = s.get("environment") or {}
        if flag(argv, "--db") is None and "INFILLD_DB" not in env:
            p.append("%s: no database: neither --db nor INFILLD_DB" % where)
        dep = (s.get("depends_on") or {})
        if not all(isinstance(dep, dict) and
                   (dep.get(n2) or {}).get("condition") == "service_healthy" for n2 in pg):
            p.append("%s: does not depend_on postgres with condition service_healthy" % where)
        store = flag(argv, "--store")
        srcs = [src for src, dst in mounts(s) if dst == store and src in named]
        if not store or not srcs:
            p.append("%s: --store %r is not a mounted named volume" % (where, store))
        stores.update(srcs)
    if len(api) < 2:
        p.append("compose-cluster.yaml: want two API services (serve), found %r" % api)
    if not workers:
        p.append("compose-cluster.yaml: no worker service")
    if len(stores) > 1:
        p.append("compose-cluster.yaml: infilld services mount different stores %r" %
                 sorted(stores))

    # The load balancer, if there is one, sends to exactly the API services.
    cfg = os.path.join(deploy, "haproxy.cfg")
    if any("haproxy" in str(s.get("image", "")) for s in services.values()):
        with open(cfg) as f:
            servers = sorted(ln.split()[2] for ln in f if ln.split()[:1] == ["server"])
        want = sorted("%s:8080" % n for n in api)
        if servers != want:
            p.append("haproxy.cfg: servers %r, the API services are %r" % (servers, want))
    return p


# ------------------------------------------------------------- kubernetes

def labels_match(selector, labels):
    return bool(selector) and all(labels.get(k) == v for k, v in selector.items())


def k8s_problems(deploy):
    p = []
    kdir = os.path.join(deploy, "k8s")
    objs = []  # (file, object)
    for path in yaml_files(kdir):
        for d in load_all(path):
            objs.append((os.path.basename(path), d))
    kinds = {}
    for f, o in objs:
        kinds.setdefault(o.get("kind"), []).append((f, o))

    kust = [o for f, o in kinds.get("Kustomization", [])]
    listed = set(kust[0].get("resources", [])) if kust else set()
    files = {os.path.basename(x) for x in yaml_files(kdir)} - {"kustomization.yaml"}
    if sorted(listed) != sorted(files):
        p.append("kustomization.yaml: resources %r, files %r" % (sorted(listed), sorted(files)))

    pvcs = {o["metadata"]["name"]: o for f, o in kinds.get("PersistentVolumeClaim", [])}
    secrets = {o["metadata"]["name"]: o for f, o in kinds.get("Secret", [])}
    for name, s in secrets.items():
        if "CHANGE-ME" not in yaml.safe_dump(s.get("stringData") or s.get("data") or {}):
            p.append("Secret %s: not the CHANGE-ME placeholder (no real secret in git)" % name)

    deployments = kinds.get("Deployment", [])
    api_pods, all_pods = [], []
    for f, d in deployments:
        where = "%s: Deployment %s" % (f, d["metadata"]["name"])
        spec = d.get("spec") or {}
        tmpl = spec.get("template") or {}
        labels = (tmpl.get("metadata") or {}).get("labels") or {}
        all_pods.append((where, labels))
        if not labels_match((spec.get("selector") or {}).get("matchLabels"), labels):
            p.append("%s: selector does not match its pod labels" % where)
        pod = tmpl.get("spec") or {}
        if (pod.get("securityContext") or {}).get("runAsNonRoot") is not True:
            p.append("%s: pod securityContext lacks runAsNonRoot: true" % where)
        vols = {v["name"]: v for v in pod.get("volumes") or []}
        for c in pod.get("containers") or []:
            cw = "%s: container %s" % (where, c.get("name"))
            lim = (c.get("resources") or {}).get("limits") or {}
            if not ("cpu" in lim and "memory" in lim):
                p.append("%s: resources.limits lacks cpu or memory" % cw)
            sc = c.get("securityContext") or {}
            if sc.get("readOnlyRootFilesystem") is not True or \
                    sc.get("allowPrivilegeEscalation") is not False:
                p.append("%s: wants readOnlyRootFilesystem and no privilege escalation" % cw)
            if c.get("command") != [INFILLD]:
                p.append("%s: command is not [%s]" % (cw, INFILLD))
                continue
            argv = c.get("args")
            p += argv_problems(cw, argv)
            if not usable(argv):
                continue
            if any("://" in a for a in argv):
                p.append("%s: a URL in args (the database URL belongs in the Secret)" % cw)
            env = {e.get("name"): e for e in c.get("env") or []}
            ref = ((env.get("INFILLD_DB") or {}).get("valueFrom") or {}).get("secretKeyRef") or {}
            if ref.get("name") not in secrets:
                p.append("%s: INFILLD_DB does not come from a Secret in deploy/k8s" % cw)
            store = flag(argv, "--store")
            mount = [m for m in c.get("volumeMounts") or [] if m.get("mountPath") == store]
            claim = ((vols.get(mount[0]["name"]) if mount else None) or {}) \
                .get("persistentVolumeClaim", {}).get("claimName")
            if claim not in pvcs:
                p.append("%s: --store %r is not a mounted PersistentVolumeClaim" % (cw, store))
            elif "ReadWriteMany" not in pvcs[claim]["spec"].get("accessModes", []):
                p.append("%s: store claim %s is not ReadWriteMany" % (cw, claim))
            if argv[0] == "serve":
                api_pods.append((where, labels, c))
                if (spec.get("replicas") or 1) < 2:
                    p.append("%s: API replicas %r, want >= 2" % (where, spec.get("replicas")))
                ports = {pt.get("name"): pt.get("containerPort") for pt in c.get("ports") or []}
                for probe, path in (("readinessProbe", "/readyz"), ("livenessProbe", "/livez")):
                    get = (c.get(probe) or {}).get("httpGet") or {}
                    port = ports.get(get.get("port"), get.get("port"))
                    if get.get("path") != path or port != 8080:
                        p.append("%s: %s wants GET %s on 8080, has %r" % (cw, probe, path, get))
            else:
                grace = pod.get("terminationGracePeriodSeconds", 30)
                if grace < 60:
                    p.append("%s: terminationGracePeriodSeconds %d, want >= 60 (the drain, 30 s,"
                             " and margin)" % (where, grace))
    if not api_pods:
        p.append("deploy/k8s: no API Deployment (serve)")

    for f, b in kinds.get("PodDisruptionBudget", []):
        sel = (b.get("spec") or {}).get("selector", {}).get("matchLabels")
        hits = [w for w, lab in all_pods if labels_match(sel, lab)]
        if len(hits) != 1:
            p.append("%s: PodDisruptionBudget %s selects %d Deployments' pods (%r), want 1" %
                     (f, b["metadata"]["name"], len(hits), sel))
    covered = [w for w, lab in all_pods
               if any(labels_match(b["spec"].get("selector", {}).get("matchLabels"), lab)
                      for f, b in kinds.get("PodDisruptionBudget", []))]
    for w, lab in all_pods:
        if w not in covered:
            p.append("%s: no PodDisruptionBudget covers its pods" % w)

    services = kinds.get("Service", [])
    if not services:
        p.append("deploy/k8s: no Service")
    for f, s in services:
        sel = (s.get("spec") or {}).get("selector")
        where = "%s: Service %s" % (f, s["metadata"]["name"])
        hits = [w for w, lab in all_pods if labels_match(sel, lab)]
        if not api_pods or hits != [w for w, lab, c in api_pods]:
            p.append("%s: selector %r selects %r, want exactly the API pods" % (where, sel, hits))
        for pt in s["spec"].get("ports") or []:
            for w, lab, c in api_pods:
                names = {x.get("name"): x.get("containerPort") for x in c.get("ports") or []}
                if pt.get("targetPort") not in names and pt.get("targetPort") not in names.values():
                    p.append("%s: targetPort %r is no port of %s" %
                             (where, pt.get("targetPort"), w))
    return p


def problems(deploy):
    return compose_problems(deploy) + k8s_problems(deploy)


# ------------------------------------------------------------------ tests

def test_yamllint_clean():
    names = [os.path.relpath(f, DEPLOY) for f in yaml_files(DEPLOY)]
    for want in ("compose.yaml", "compose-cluster.yaml", "k8s/api.yaml", "k8s/worker.yaml",
                 "k8s/pdb.yaml", "k8s/kustomization.yaml"):
        check(want in names, "%s among the linted files %r" % (want, names))
    rc, out = yamllint(DEPLOY)
    check(rc == 0 and not out, "yamllint (status %d):\n%s" % (rc, out))


def test_yamllint_catches():
    d = tempfile.mkdtemp(prefix="infilld-lint-")
    try:
        with open(os.path.join(d, "bad.yaml"), "w") as f:
            f.write("services:\n  x:\n    read_only: yes\n    command: [ serve, --listen ]\n"
                    "    image: " + "x" * 100 + "\n")
        rc, out = yamllint(d)
        print(out)
        check(rc != 0, "yamllint passed a bad file")
        for rule in ("(truthy)", "(line-length)", "(brackets)"):
            check(rule in out, "yamllint reports %s: %s" % (rule, out))
    finally:
        shutil.rmtree(d, ignore_errors=True)


def test_structure():
    found = problems(DEPLOY)
    check(not found, "deploy/ structure:\n  " + "\n  ".join(found))


def mutated(rel, change):
    """Problems of a copy of deploy/ whose file REL is loaded, changed by
    CHANGE(list of documents) and written back."""
    d = tempfile.mkdtemp(prefix="infilld-deploy-")
    try:
        dst = os.path.join(d, "deploy")
        shutil.copytree(DEPLOY, dst)
        docs = load_all(os.path.join(dst, rel))
        docs = copy.deepcopy(docs)
        change(docs)
        with open(os.path.join(dst, rel), "w") as f:
            yaml.safe_dump_all(docs, f, sort_keys=False)
        return problems(dst)
    finally:
        shutil.rmtree(d, ignore_errors=True)


def container(docs):
    return docs[0]["spec"]["template"]["spec"]["containers"][0]


def set_arg(old, new):
    def change(docs):
        args = container(docs)["args"]
        args[args.index(old)] = new
    return change


def compose_service(name, fn):
    def change(docs):
        svc = dict(docs[0]["services"][name])  # api-1 and api-2 share one node
        fn(svc)
        docs[0]["services"][name] = svc
    return change


BROKEN = [
    ("PDB selector matches no pods", "k8s/pdb.yaml",
     lambda docs: docs[1]["spec"]["selector"]["matchLabels"].update(
         {"app.kubernetes.io/component": "workers"}),
     "PodDisruptionBudget infilld-worker selects 0"),
    ("Service selects the workers", "k8s/api-service.yaml",
     lambda docs: docs[0]["spec"]["selector"].update({"app.kubernetes.io/component": "worker"}),
     "want exactly the API pods"),
    ("flag typo --slot", "k8s/worker.yaml", set_arg("--slots", "--slot"),
     "unknown flag '--slot'"),
    ("serve-only flag on a worker", "k8s/worker.yaml", set_arg("--slots", "--workers"),
     "unknown flag '--workers'"),
    ("sub-command typo", "k8s/api.yaml", set_arg("serve", "server"),
     "unknown sub-command 'server'"),
    ("no readiness probe", "k8s/api.yaml", lambda docs: container(docs).pop("readinessProbe"),
     "readinessProbe wants GET /readyz"),
    ("liveness on the wrong path", "k8s/api.yaml",
     lambda docs: container(docs)["livenessProbe"]["httpGet"].update({"path": "/readyz"}),
     "livenessProbe wants GET /livez"),
    ("worker without limits", "k8s/worker.yaml",
     lambda docs: container(docs)["resources"].pop("limits"), "resources.limits lacks"),
    ("a numeric argument", "k8s/api.yaml", set_arg("0", 0), "argument 0 is not a string"),
    ("short grace for the drain", "k8s/worker.yaml",
     lambda docs: docs[0]["spec"]["template"]["spec"].update(
         {"terminationGracePeriodSeconds": 30}), "terminationGracePeriodSeconds 30"),
    ("store claim not RWX", "k8s/store-pvc.yaml",
     lambda docs: docs[0]["spec"].update({"accessModes": ["ReadWriteOnce"]}),
     "is not ReadWriteMany"),
    ("compose worker replicas 1", "compose-cluster.yaml",
     compose_service("worker", lambda s: s.update({"deploy": {"replicas": 1}})),
     "worker deploy.replicas 1"),
    ("compose postgres without healthcheck", "compose-cluster.yaml",
     compose_service("postgres", lambda s: s.pop("healthcheck")), "no pg_isready healthcheck"),
    ("compose API flag typo", "compose-cluster.yaml",
     compose_service("api-2", lambda s: s.update(
         {"command": ["serve", "--listen", "0.0.0.0:8080", "--stor", "/srv/infilld-store",
                      "--workers", "0"]})), "unknown flag '--stor'"),
    ("compose API server not hardened", "compose-cluster.yaml",
     compose_service("api-1", lambda s: s.pop("read_only")), "lacks the hardening"),
    ("compose one API server", "compose-cluster.yaml",
     lambda docs: docs[0]["services"].pop("api-2"), "want two API services"),
]


def test_structure_catches():
    for what, rel, change, want in BROKEN:
        found = mutated(rel, change)
        print("%s (%s):\n  %s" % (what, rel, "\n  ".join(found) or "(nothing)"))
        check(any(want in x for x in found), "%s: no problem saying %r in %r" % (what, want, found))


if __name__ == "__main__":
    run([test_yamllint_clean, test_yamllint_catches, test_structure, test_structure_catches])
