"""Names: a mesh name that is not UTF-8 text is refused (422, field name)
before anything is stored or charged, by query and by multipart filename;
errors name the client's file, never temporary files, data-directory
paths or uninitialised numbers."""
import glob
import os
import re
import sys
import time

sys.path.insert(0, os.path.dirname(os.path.abspath(__file__)))
from svc import SHARED, Server, check, run  # noqa: E402

P = os.path.join(SHARED, "meshes", "P.off")
srv = Server(workers=1)
S = {}


def setup():
    srv.start()
    S["admin"] = srv.admin_key()
    t = srv.json("POST", "/v1/tenants", {"name": "n"}, key=S["admin"], expect=201)
    S["key"] = t["api_key"]


def used():
    return srv.json("GET", "/v1/tenants/n", key=S["admin"])["used_bytes"]


def meshes():
    return srv.json("GET", "/v1/meshes", key=S["key"])["meshes"]


def multipart(filename, data):
    b = b"----infilldtest"
    body = (b"--" + b + b"\r\nContent-Disposition: form-data; name=\"file\"; filename=\"" +
            filename + b"\"\r\nContent-Type: application/octet-stream\r\n\r\n" + data +
            b"\r\n--" + b + b"--\r\n")
    return srv.request("POST", "/v1/meshes?format=off", body,
                       {"Content-Type": "multipart/form-data; boundary=" + b.decode()},
                       S["key"], timeout=5)


def test_invalid_utf8_name():
    data = open(P, "rb").read()
    before_used, before_n = used(), len(meshes())
    for q in ("%ff%fe", "a%c0%afb", "%ed%a0%80", "x%0Ay"):
        r = srv.request("POST", "/v1/meshes?format=off&name=" + q, data,
                        {"Content-Type": "application/octet-stream"}, S["key"], timeout=5)
        check(r.problem(422, "invalid-parameter").get("field") == "name",
              "query name %s: field name" % q)
    r = multipart(b"\xff\xfe.off", data)
    check(r.problem(422, "invalid-parameter").get("field") == "name", "multipart filename")
    check(used() == before_used, "nothing charged: %d vs %d" % (used(), before_used))
    check(len(meshes()) == before_n, "nothing stored")
    # Upload temporaries are named up-*; the workers' store probe (.probe-*, written and
    # removed every 2 s by store_check) may be caught in passing and is not one of them.
    tmp = [f for f in os.listdir(os.path.join(srv.data, "tmp")) if f.startswith("up-")]
    check(not tmp, "no upload temp files left: %s" % tmp)
    # Valid UTF-8 names are kept as sent.
    r = srv.request("POST", "/v1/meshes?format=off&name=%C3%A9l%C3%A9phant.off", data,
                    {"Content-Type": "application/octet-stream"}, S["key"], timeout=5)
    check(r.status == 201 and r.json()["name"] == "\u00e9l\u00e9phant.off", "utf-8 name kept")


def clean(detail):
    """No temporary names, data-directory paths or garbage numbers."""
    check("up-" not in detail and "/tmp" not in detail and srv.data not in detail and
          os.path.realpath(srv.data) not in detail, "internal path in %r" % detail)
    check(not re.search(r"\d{7,}", detail), "garbage number in %r" % detail)


def test_errors_name_client_files():
    r = srv.request("POST", "/v1/tenants", {"name": "../x"}, key=S["admin"])
    p = r.problem(422, "invalid-parameter")
    check(p.get("field") == "name", "tenant name field: %s" % p)
    clean(p["detail"])
    broken = sorted(glob.glob(os.path.join(SHARED, "meshes", "broken", "*.stl")))
    seen = 0
    for path in broken:
        r = srv.request("POST", "/v1/meshes?format=stl&name=client-part.stl",
                        open(path, "rb").read(), {"Content-Type": "model/stl"}, S["key"],
                        timeout=10)
        if r.status == 201:
            continue
        p = r.problem(422)
        clean(p["detail"])
        if "client-part.stl" in p["detail"]:
            seen += 1
        print("     %s: %s" % (os.path.basename(path), p["detail"]))
    check(seen > 0, "broken meshes' errors name the client's file")
    # A job's error names the mesh by the client's name, not its stored file.
    mesh = srv.upload(P, S["key"], name="my-part.off").json()["id"]
    for f in glob.glob(os.path.join(srv.data, "tenants", "*", "meshes", mesh + ".*")):
        os.unlink(f)  # lost on disk (a bad restore): the reader names the path
    jid = srv.submit(S["key"], mesh, format="sl1", params={"height_mm": 5}).json()["id"]
    j = srv.wait_job(S["key"], jid)
    check(j["state"] == "failed", "mesh file missing: %s" % j["state"])
    check("my-part.off" in j["error"]["detail"], "names the client's file")
    print("     job: %s" % j["error"]["detail"])
    clean(j["error"]["detail"])
    check(mesh not in j["error"]["detail"], "no stored file name in %r" % j["error"]["detail"])


def sl1_job(name):
    mesh = srv.upload(P, S["key"], name=name).json()["id"]
    jid = srv.submit(S["key"], mesh, format="sl1", params={"height_mm": 2}).json()["id"]
    check(srv.wait_job(S["key"], jid)["state"] == "succeeded", "sl1 job")
    return srv.request("GET", "/v1/jobs/%s/output" % jid, key=S["key"])


def test_output_names():
    """Outputs carry the mesh's name (sanitised), not j_<id>."""
    import io
    import urllib.parse
    import zipfile
    r = sl1_job("Gear%20Wheel%20(v2).off")
    disp = r.header("Content-Disposition")
    check('filename="Gear_Wheel_v2_.sl1"' in disp, "ASCII filename: %s" % disp)
    m = re.search(r"filename\*=UTF-8''(\S+)", disp)
    check(m and urllib.parse.unquote(m.group(1)) == "Gear Wheel (v2).sl1", "filename*: %s" % disp)
    z = zipfile.ZipFile(io.BytesIO(r.body))
    ini = z.read("config.ini").decode()
    check("jobDir = Gear_Wheel_v2_" in ini, "jobDir from the mesh name: %s" % ini[:200])
    check(any(n.startswith("Gear_Wheel_v2_") and n.endswith(".png") for n in z.namelist()),
          "layers named after the mesh: %s" % z.namelist()[:5])
    # Non-ASCII and "thumbnail" never reach the archive's names.
    r = sl1_job("%C3%A9l%C3%A9-Thumbnail.off")
    disp = r.header("Content-Disposition")
    check('filename="_l_-.sl1"' in disp, "sanitised: %s" % disp)
    m = re.search(r"filename\*=UTF-8''(\S+)", disp)
    check(urllib.parse.unquote(m.group(1)) == "\u00e9l\u00e9-Thumbnail.sl1", "utf-8 kept in filename*")
    z = zipfile.ZipFile(io.BytesIO(r.body))
    layers = [n for n in z.namelist() if n.endswith(".png") and not n.startswith("thumbnail/")]
    check(layers and all("thumbnail" not in n.lower() for n in layers), "layers: %s" % layers[:3])
    check(all(ord(c) < 128 for n in layers for c in n), "ASCII layer names")


def teardown():
    srv.cleanup()


if __name__ == "__main__":
    try:
        setup()
        run([test_invalid_utf8_name, test_errors_name_client_files, test_output_names,
             teardown])
    finally:
        srv.cleanup()
