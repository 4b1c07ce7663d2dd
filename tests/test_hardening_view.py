"""Hardening of `plantlod view` and `plantlod export` (issue 24): a glTF is carried only when
it is whole (GLB header and chunks, every index and byte range within what the file holds),
and random glTF bytes and argument lists may only ever end in exit 0, 1 or 2 with one line."""

from __future__ import annotations

import json
import os
import struct

import pytest
from hypothesis import HealthCheck, given, settings
from hypothesis import strategies as st

import plantlod
from golden_util import ROOT, run_cli
from plantlod.export.view import glb_from_file
from plantlod.lsys.errors import InputError
from test_hardening_cli import no_temporary_files, one_line

STALK = str(ROOT / "examples" / "stalk8.lsys")


@pytest.fixture(scope="module")
def files(tmp_path_factory):
    folder = tmp_path_factory.mktemp("hv")
    tree = plantlod.derive(plantlod.read_lsystem(STALK))
    angles = plantlod.simulate(tree, wind=(5.0, 0.0, 0.0), dt=0.01, steps=50, every=5)
    plantlod.export_animation(tree, angles, folder / "s.glb")
    plantlod.export_animation(tree, angles, folder / "s.gltf")
    run_cli("simulate", STALK, "--dt", "0.01", "--steps", "50", "--wind-speed", "5",
            "-o", str(folder / "s.csv"))
    return folder


def glb_parts(path) -> tuple[dict, bytes]:
    data = path.read_bytes()
    size = struct.unpack_from("<I", data, 12)[0]
    doc = json.loads(data[20:20 + size])
    return doc, data[20 + size + 8:]


def make_glb(doc: dict, blob: bytes) -> bytes:
    text = json.dumps(doc).encode()
    text += b" " * (-len(text) % 4)
    blob += b"\0" * (-len(blob) % 4)
    body = struct.pack("<II", len(text), 0x4E4F534A) + text + struct.pack("<II", len(blob),
                                                                          0x004E4942) + blob
    return struct.pack("<4sII", b"glTF", 2, 12 + len(body)) + body


def view_refuses(tmp_path, data: bytes, *fragments: str) -> str:
    path = tmp_path / "x.glb"
    path.write_bytes(data)
    out = tmp_path / "page.html"
    line = one_line(run_cli("view", str(path), "-o", str(out), exit_code=None), 2,
                    f"{path}: error:", *fragments)
    assert not out.exists()
    no_temporary_files(tmp_path)
    return line


@pytest.mark.parametrize("keep", [0.95, 0.6, 0.5])
def test_a_truncated_glb_is_bad_input(files, tmp_path, keep):
    data = (files / "s.glb").read_bytes()
    view_refuses(tmp_path, data[:int(len(data) * keep)], "")


def test_a_whole_file_still_makes_a_page(files, tmp_path):
    run_cli("view", str(files / "s.glb"), str(files / "s.gltf"), "-o", str(tmp_path / "p.html"))
    assert (tmp_path / "p.html").stat().st_size > 10_000


@pytest.mark.parametrize("edit, fragment", [
    (lambda d: d["accessors"][0].update(count=10**9), "accessors[0] needs"),
    (lambda d: d["accessors"][0].update(bufferView=99), "accessors[0].bufferView is 99"),
    (lambda d: d["accessors"][0].update(componentType=1), "componentType is 1"),
    (lambda d: d["accessors"][0].update(count=-1), "count must be a whole number"),
    (lambda d: d["bufferViews"][0].update(byteLength=10**9), "bufferViews[0] spans bytes"),
    (lambda d: d["buffers"][0].update(byteLength=10**9), "buffers[0] declares"),
    (lambda d: d["nodes"][0].update(children=[0]), "more than one parent"),
    (lambda d: d["nodes"][1].update(children=[0]), "own ancestors"),
    (lambda d: d["nodes"][0].update(mesh=50), "nodes[0].mesh is 50"),
    (lambda d: d["animations"][0]["channels"][0]["target"].update(node=10**6), "target.node"),
    (lambda d: d["animations"][0]["samplers"][0].update(input=-1), "samplers[0].input is -1"),
    (lambda d: d["meshes"][0]["primitives"][0].update(indices=77), "indices is 77"),
    (lambda d: d.update(scene=3), "scene is 3"),
    (lambda d: d["buffers"].append({"byteLength": 4}), "2 buffers"),
    # dangling references the page's loader follows (session 23, found by fuzzing)
    (lambda d: d["nodes"][1].update(skin=999), "nodes[1].skin is 999"),
    (lambda d: d["nodes"][1].update(camera=999), "nodes[1].camera is 999"),
    (lambda d: d.update(textures=[{"source": 999}]), "textures[0].source is 999"),
    (lambda d: d.update(images=[{"bufferView": 999}]), "images[0].bufferView is 999"),
    (lambda d: d["accessors"][0].update(sparse={"count": 1, "indices": {"bufferView": 999, "componentType": 5125},
                                                "values": {"bufferView": 0}}),
     "accessors[0].sparse.indices.bufferView is 999"),
    (lambda d: d["animations"][0]["channels"][0]["target"].update(path="zzz"), "target.path is 'zzz'"),
    (lambda d: d["meshes"][0]["primitives"][0].update(targets=[{"POSITION": 999}]),
     "primitives[0].targets[0].POSITION is 999"),
    # values of another JSON type that the page's three.js throws on (session 42, fuzzing)
    (lambda d: d["animations"][0]["channels"][0].update(sampler=True),
     "channels[0].sampler is True"),
    (lambda d: d["animations"][0].update(channels={}), "animations[0].channels is {}; expected a list"),
    (lambda d: d["animations"][0].pop("channels"), "animations[0] has no channels"),
    (lambda d: d["nodes"][0].update(name=5), "nodes[0].name is 5; expected a string"),
    (lambda d: d["nodes"][1].update(name={"a": 1}), 'nodes[1].name is {"a": 1}'),
    # a GLB's binary chunk is buffer 0's only where it has no uri: an empty data: URI was
    # written into the page as a buffer of 0 bytes (session 42, fuzzing)
    (lambda d: d["buffers"][0].update(uri="data:application/octet-stream;base64,"),
     "buffers[0] has a uri, but the GLB's binary chunk"),
])
def test_indices_and_lengths_are_checked(files, tmp_path, edit, fragment):
    doc, blob = glb_parts(files / "s.glb")
    edit(doc)
    view_refuses(tmp_path, make_glb(doc, blob), fragment)


@pytest.mark.parametrize("edit, fragment", [
    # a JSON null where glTF has an object was an internal error (AttributeError) in any
    # list of objects, top-level or nested (session 26, found by fuzzing)
    (lambda d: d["nodes"].__setitem__(0, None), "nodes[0] is null; expected an object"),
    (lambda d: d.update(scenes=[None]), "scenes[0] is null"),
    (lambda d: d["accessors"].__setitem__(1, None), "accessors[1] is null"),
    (lambda d: d["bufferViews"].__setitem__(0, None), "bufferViews[0] is null"),
    (lambda d: d.update(cameras=[None]), "cameras[0] is null"),
    (lambda d: d.update(samplers=[None]), "samplers[0] is null"),
    (lambda d: d["animations"][0]["channels"].__setitem__(0, None),
     "animations[0].channels[0] is null"),
    (lambda d: d["animations"][0]["samplers"].__setitem__(0, None),
     "animations[0].samplers[0] is null"),
])
def test_a_null_where_glTF_has_an_object_is_bad_input(files, tmp_path, edit, fragment):
    doc, blob = glb_parts(files / "s.glb")
    edit(doc)
    view_refuses(tmp_path, make_glb(doc, blob), fragment)


def test_buffer_uris_as_glTF_writes_them(files, tmp_path):
    # glTF 2.0's own data-URI type and a percent-encoded file name (both refused before,
    # the second as "holds 0 bytes"): the same page as the file plantlod wrote
    import base64

    doc = json.loads((files / "s.gltf").read_text())
    data = base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1])
    pages = {}
    for name, uri in (("own", doc["buffers"][0]["uri"]),
                      ("gltf-buffer", "data:application/gltf-buffer;base64,"
                       + base64.b64encode(data).decode()),
                      ("encoded", "buf%2Ebin")):
        (tmp_path / "buf.bin").write_bytes(data)
        doc["buffers"][0]["uri"] = uri
        path = tmp_path / "t.gltf"
        path.write_text(json.dumps(doc))
        pages[name] = glb_from_file(str(path))
    assert pages["gltf-buffer"] == pages["own"] == pages["encoded"]


def test_external_buffers_are_checked(files, tmp_path):
    doc = json.loads((files / "s.gltf").read_text())
    (tmp_path / "folder.bin").mkdir()
    # a buffer file is one beside the glTF: no folder, no path out of it (a page must not
    # carry /etc/passwd), no NUL byte (an internal error before session 21)
    for uri, fragment in [("missing.bin", "No such file"), ("folder.bin", "not a regular file"),
                          ("http://example.com/x.bin", "expected a data: URI"),
                          ("/dev/zero", "beside the glTF"), ("../s.bin", "beside the glTF"),
                          ("sub/s.bin", "beside the glTF"), ("s%00.bin", "beside the glTF"),
                          ("..", "beside the glTF")]:
        doc["buffers"][0]["uri"] = uri
        path = tmp_path / "e.gltf"
        path.write_text(json.dumps(doc))
        with pytest.raises(InputError, match=fragment):
            glb_from_file(str(path))


def test_a_buffer_link_out_of_the_folder_is_refused_and_a_page_never_replaces_a_buffer(
        files, tmp_path):
    """A buffer file beside the glTF that links out of its folder was carried into the page
    (a page must not carry /etc/passwd); `view t.gltf -o t.bin` replaced the glTF's own
    buffer with the page, exit 0 (session 30, found by fuzzing)."""
    import base64

    doc = json.loads((files / "s.gltf").read_text())
    data = base64.b64decode(doc["buffers"][0]["uri"].split(",", 1)[1])
    (tmp_path / "out").mkdir()
    (tmp_path / "out" / "far.bin").write_bytes(data)
    (tmp_path / "near.bin").symlink_to(tmp_path / "out" / "far.bin")
    doc["buffers"][0]["uri"] = "near.bin"
    (tmp_path / "l.gltf").write_text(json.dumps(doc))
    with pytest.raises(InputError, match="is a link out of the glTF's folder"):
        glb_from_file(str(tmp_path / "l.gltf"))
    (tmp_path / "t.bin").write_bytes(data)
    doc["buffers"][0]["uri"] = "t.bin"
    (tmp_path / "t.gltf").write_text(json.dumps(doc))
    line = one_line(run_cli("view", str(tmp_path / "t.gltf"), "-o", str(tmp_path / "t.bin"),
                            exit_code=None), 2, "-o would write over the input")
    assert "(input 1's buffer 1)" in line
    with pytest.raises(InputError, match="its buffer"):
        plantlod.write_view([str(tmp_path / "t.gltf")], str(tmp_path / "t.bin"))
    assert (tmp_path / "t.bin").read_bytes() == data


@pytest.mark.parametrize("edit, message", [
    # pygltflib casts these before the checks see them (1.5 read as 1, "3" as 3), and chokes
    # on NaN with Python's own words (session 30, found by fuzzing)
    (lambda d: d["accessors"][0].update(count=1.5), r"accessors\[0\].count is 1.5; expected a whole"),
    (lambda d: d["accessors"][0].update(count="3"), r'accessors\[0\].count is "3"; expected a whole'),
    (lambda d: d["nodes"][0].update(rotation=[0, 0, 0]), r"nodes\[0\].rotation is \[0, 0, 0\]; expected 4"),
    (lambda d: d["nodes"][0].update(matrix=[1] * 15), r"nodes\[0\].matrix is .*; expected 16 numbers"),
    (lambda d: d["meshes"][0]["primitives"][0].update(mode=99), r"mode is 99; expected 0..6"),
    (lambda d: d["animations"][0]["samplers"][0].update(interpolation="CUBIC"),
     r'interpolation is "CUBIC"; expected LINEAR, STEP or CUBICSPLINE'),
    (lambda d: d["animations"][0]["samplers"][0].update(
        input=d["animations"][0]["samplers"][0]["output"]), r"expected a SCALAR of floats"),
    (lambda d: d["accessors"][0].update(min=float("nan")), r"JSON holds NaN, which JSON has no number"),
])
def test_values_the_gltf_reader_would_cast_are_refused(files, tmp_path, edit, message):
    doc = json.loads((files / "s.gltf").read_text())
    edit(doc)
    path = tmp_path / "t.gltf"
    path.write_text(json.dumps(doc))                 # (json writes NaN as the literal NaN)
    with pytest.raises(InputError, match=message):
        glb_from_file(str(path))


@pytest.mark.parametrize("device", ["/dev/zero", "fifo"])
def test_a_file_that_is_not_regular_is_refused_before_reading(tmp_path, device):
    """/dev/zero was read without end by the glTF reader (memory, then killed with a
    temporary left); a pipe waited for a writer (session 21, found by fuzzing)."""
    path = device
    if device == "fifo":
        path = str(tmp_path / "p.glb")
        os.mkfifo(path)
    with pytest.raises(InputError, match="not a regular file"):
        glb_from_file(path)


def test_a_file_too_large_is_refused_before_reading(files, tmp_path, monkeypatch):
    import plantlod.export.view as view

    monkeypatch.setattr(view, "VIEW_MAX_FILE_BYTES", 100)
    with pytest.raises(InputError, match="more than the limit of 100"):
        glb_from_file(str(files / "s.glb"))


@settings(max_examples=200, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(st.data())
def test_random_corruptions_of_a_glb(files, tmp_path, data):
    raw = bytearray((files / ("s.glb" if data.draw(st.booleans()) else "s.gltf")).read_bytes())
    for _ in range(data.draw(st.integers(1, 8))):
        at = data.draw(st.integers(0, len(raw) - 1))
        raw[at] = data.draw(st.integers(0, 255))
    if data.draw(st.booleans()):
        raw = raw[:data.draw(st.integers(0, len(raw)))]
    path = tmp_path / ("r.glb" if data.draw(st.booleans()) else "r.gltf")
    path.write_bytes(bytes(raw))
    try:
        glb_from_file(str(path))
    except InputError:
        pass


JSON_VALUES = st.sampled_from([None, -1, 0, 1, 3, 10**12, 1.5, "x", [], {}, [0], [-1], True])
GLTF_KEYS = st.sampled_from([
    ("accessors", 0, "count"), ("accessors", 0, "bufferView"), ("accessors", 0, "byteOffset"),
    ("accessors", 0, "type"), ("accessors", 0, "componentType"), ("bufferViews", 0, "buffer"),
    ("bufferViews", 0, "byteLength"), ("bufferViews", 0, "byteStride"), ("buffers", 0, "byteLength"),
    ("nodes", 0, "children"), ("nodes", 1, "mesh"), ("meshes", 0, "primitives"),
    ("animations", 0, "samplers"), ("animations", 0, "channels"), ("scenes", 0, "nodes"),
])


@settings(max_examples=200, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(st.lists(st.tuples(GLTF_KEYS, JSON_VALUES), min_size=1, max_size=3))
def test_random_values_in_a_glb(files, tmp_path, edits):
    doc, blob = glb_parts(files / "s.glb")
    for (table, index, key), value in edits:
        doc[table][index][key] = value
    path = tmp_path / "v.glb"
    path.write_bytes(make_glb(doc, blob))
    try:
        glb_from_file(str(path))
    except InputError:
        pass


# --- random argument lists of export and view -------------------------------------------

def _tokens(folder) -> st.SearchStrategy:
    f = str(folder)
    return st.sampled_from([
        "export", "view", STALK, f"{f}/s.csv", f"{f}/s.glb", f"{f}/s.gltf", f"{f}/none.glb",
        f"{f}/none.csv", f"{f}/none.npz", f, "-", "-o", f"{f}/out/x.glb", "/dev/null",
        "/dev/full", f"{f}/o.glb", f"{f}/o.gltf", f"{f}/o.usda", f"{f}/o.html", f"{f}/o.txt",
        "--fps", "30", "0", "-1", "nan", "1e400", "1001", "--frames", "0:3", "3:1", "a:b", "0:",
        "--degrees", "--wind-direction", "90", "inf", "--title", "<t>", "", "x" * 300,
    ])


@pytest.fixture(scope="module")
def fuzz_files(files, tmp_path_factory):
    """Copies of the inputs that random commands may also overwrite (and their folder,
    where an option taken as an output name lands)."""
    import shutil

    folder = tmp_path_factory.mktemp("fuzz")
    for name in ("s.csv", "s.glb", "s.gltf"):
        shutil.copy(files / name, folder / name)
    return folder


@settings(max_examples=120, deadline=None,
          suppress_health_check=[HealthCheck.too_slow, HealthCheck.function_scoped_fixture])
@given(st.data())
def test_random_export_and_view_arguments_follow_the_discipline(fuzz_files, data):
    files = fuzz_files
    args = data.draw(st.lists(_tokens(files), min_size=1, max_size=8))
    result = run_cli(*args, exit_code=None, cwd=files)
    assert result.exit_code in (0, 1, 2), (args, result.exit_code, result.stderr)
    assert "Traceback" not in result.stderr and "internal error" not in result.stderr, args
    if result.exit_code:
        assert "error:" in result.stderr.strip().splitlines()[-1], (args, result.stderr)
    for name in os.listdir(files):
        assert not name.startswith(".plantlod-"), name


@pytest.mark.parametrize("signum", [2, 15])
def test_a_signal_during_export_leaves_no_temporary_file(files, tmp_path, signum):
    from test_hardening_scene import SLOWED, _signal_when_a_temporary_appears

    out = tmp_path / "out"
    out.mkdir()
    script = SLOWED.format(module="plantlod.export.gltf", name="gltf_bytes", extra="")
    _signal_when_a_temporary_appears(out, script, ["export", STALK, str(files / "s.csv"), "-o",
                                                   str(out / "x.glb")], signum)
    assert os.listdir(out) == []


def test_a_disk_filling_up_during_export_is_exit_1(files, tmp_path):
    import subprocess

    from test_hardening_cli import PLANTLOD

    done = subprocess.run(["bash", "-c", f"trap '' XFSZ; ulimit -f 4; {PLANTLOD} export {STALK} "
                           f"{files / 's.csv'} -o {tmp_path / 'x.gltf'}"], cwd=ROOT,
                          capture_output=True, text=True, timeout=120)
    assert done.returncode == 1 and "File too large" in done.stderr, done.stderr
    assert os.listdir(tmp_path) == []


@pytest.mark.parametrize("text, reason", [
    ('{"asset": {"version": "2.0"}, "nodes": ' + "[" * 100_000 + "]" * 100_000 + "}",
     "its JSON is nested too deeply"),
    ('{"asset": {"version": "2.0"}, "nodes": {"a": 1}}', "a member is not of the kind glTF 2.0"),
])
def test_a_gltf_that_does_not_parse_is_said_in_words(tmp_path, text, reason):
    """The messages named Python's exceptions ('RecursionError: maximum recursion depth
    exceeded', 'AttributeError: 'list' object has no attribute …'; found by fuzzing)."""
    path = tmp_path / "x.gltf"
    path.write_text(text)
    line = one_line(run_cli("view", str(path), "-o", str(tmp_path / "p.html"), exit_code=None), 2,
                    f"{path}: error: not a glTF file ({reason}")
    assert "Error" not in line


def test_inputs_of_another_kind_are_named(files, tmp_path):
    # a tree .npz was "not a glTF file (its JSON is not UTF-8 text)", '-' was "no such
    # file", and a 5,000-digit number let Python's own advice through
    (tmp_path / "t.npz").write_bytes(b"PK\x03\x04" + b"\0" * 64)
    out = str(tmp_path / "p.html")
    one_line(run_cli("view", str(tmp_path / "t.npz"), "-o", out, exit_code=None), 2,
             "a zip archive (a tree or angles .npz?), not a glTF")
    one_line(run_cli("view", "-", "-o", out, exit_code=None), 2, "standard input ('-') is not read")
    doc = json.loads((files / "s.gltf").read_text())
    text = json.dumps(doc).replace('"asset": {', '"asset": {"big": 1' + "0" * 5000 + ", ", 1)
    (tmp_path / "big.gltf").write_text(text)
    line = one_line(run_cli("view", str(tmp_path / "big.gltf"), "-o", out, exit_code=None), 2,
                    "more digits than Python reads")
    assert "sys.set_int_max_str_digits" not in line
    assert not os.path.exists(out)


def _set_float(doc: dict, blob: bytes, accessor: int, row: int, value: float) -> bytes:
    """``blob`` with the first float of element ``row`` of ``accessor`` set to ``value``
    (located from the JSON alone: its view's offset, its own, a tightly packed element)."""
    acc = doc["accessors"][accessor]
    view = doc["bufferViews"][acc["bufferView"]]
    width = {"SCALAR": 1, "VEC3": 3, "VEC4": 4}[acc["type"]]
    at = view.get("byteOffset", 0) + acc.get("byteOffset", 0) + row * (view.get("byteStride") or 4 * width)
    return blob[:at] + struct.pack("<f", value) + blob[at + 4:]


def _sampler(doc: dict) -> dict:
    return doc["animations"][0]["samplers"][doc["animations"][0]["channels"][0]["sampler"]]


@pytest.mark.parametrize("edit, fragment", [
    # what a page's loader refuses, or hangs on, though every index and length holds (a
    # helper's fuzzing, session 33): the document ...
    (lambda d, b: (d.pop("asset"), b)[1], "the glTF has no asset"),
    (lambda d, b: (d["asset"].update(version="1.0"), b)[1], 'asset.version is "1.0"; expected "2.0"'),
    (lambda d, b: (d["accessors"][0].update(bufferView=None), b)[1],
     "accessors[0].bufferView is null"),
    (lambda d, b: (d["accessors"][0].update(normalized="yes"), b)[1],
     'accessors[0].normalized is "yes"; expected true or false'),
    (lambda d, b: (_sampler(d).update(output=_sampler(d)["input"]), b)[1],
     "(rotation): its output accessors"),
    (lambda d, b: (d["accessors"][_sampler(d)["output"]].update(
        count=d["accessors"][_sampler(d)["output"]]["count"] // 2), b)[1],
     "key times but"),
    (lambda d, b: (_sampler(d).update(interpolation="CUBICSPLINE"), b)[1], "; expected 3 x "),
    (lambda d, b: (d["accessors"][_sampler(d)["input"]].update(count=0), b)[1],
     "which holds no key times"),
    (lambda d, b: (d["scenes"][0]["nodes"].append(d["nodes"][0]["children"][0]), b)[1],
     "which is another node's child"),
    (lambda d, b: (d["scenes"][0]["nodes"].append(d["scenes"][0]["nodes"][0]), b)[1], "twice"),
    # ... and the animation's numbers
    (lambda d, b: _set_float(d, b, _sampler(d)["output"], 3, float("nan")),
     "output value 3 is not finite"),
    (lambda d, b: _set_float(d, b, _sampler(d)["input"], 2, -1.0),
     "key time 2 (-1 s) is not after the one before"),
    (lambda d, b: _set_float(d, b, _sampler(d)["input"], 0, float("inf")), "key time 0 is not finite"),
])
def test_what_a_page_cannot_play_is_refused(files, tmp_path, edit, fragment):
    doc, blob = glb_parts(files / "s.glb")
    blob = edit(doc, blob)
    view_refuses(tmp_path, make_glb(doc, blob), fragment)


def test_a_gltf_whose_json_is_broken_names_the_line_and_column(tmp_path):
    """A .gltf (JSON text) that is not JSON: the place in the file, as every reader gives it,
    not inside Python's wording ("(Expecting value: line 2 column 13 (char 42))"; a helper's
    fuzzing, session 33)."""
    text = '{"asset": {"version": "2.0"},\n "nodes": [ , ]}\n'
    path = tmp_path / "x.gltf"
    path.write_text(text)
    line, col = 2, text.splitlines()[1].index(",") + 1           # the stray comma
    result = run_cli("view", str(path), "-o", str(tmp_path / "p.html"), exit_code=2)
    assert result.stderr == (f"{path}:{line}:{col}: error: not a glTF file: its JSON is not "
                             "valid (Expecting value)\n")


def test_a_large_file_of_another_kind_is_refused_by_its_start(tmp_path):
    """A 900 MB file of zeros named .glb was read whole (twice: once to find the glTF's own
    buffer files, once to play it) only to be refused by its first four bytes, and /dev/zero
    named .npz was read to the 2 GiB limit (a fuzzing round: 1.9-2.1 GB, 6-10 s). Under a
    700 MB address-space cap that reading ran out of memory (exit 1); read by their starts,
    both are refused as what they are, exit 2."""
    import subprocess

    glb = tmp_path / "d.glb"
    with open(glb, "wb") as f:
        f.truncate(900 << 20)                    # (sparse: no disk used)
    os.symlink("/dev/zero", tmp_path / "z.npz")
    capped = ["bash", "-c", 'ulimit -v 700000 && exec "$@"', "bash",
              str(ROOT / ".venv" / "bin" / "plantlod")]
    for args, message in ((("view", "d.glb", "-o", "v.html"),
                           "d.glb: error: not a glTF file (a .glb starts with 'glTF')"),
                          (("simulate", "z.npz", "--dt", "0.01", "--steps", "5",
                            "--wind-speed", "1"),
                           "z.npz: error: not a readable archive: File is not a zip file")):
        done = subprocess.run(capped + list(args), cwd=tmp_path, capture_output=True, text=True,
                              timeout=120)
        assert done.returncode == 2, done.stderr
        assert done.stderr.startswith(message) and done.stderr.count("\n") == 1, done.stderr
    assert not (tmp_path / "v.html").exists()


def test_a_gltf_that_is_not_utf8_is_placed(tmp_path):
    """A .gltf with a Latin-1 byte was "not a glTF file (its JSON is not UTF-8 text)", with
    no place, where every other reader gives LINE:COL (a fuzzing round)."""
    path = tmp_path / "l.gltf"
    path.write_bytes(b'{"asset": {"version": "2.0"},\n  "nodes": [{"name": "caf\xe9"}]}\n')
    one_line(run_cli("view", str(path), "-o", str(tmp_path / "v.html"), exit_code=None), 2,
             f"{path}:2:26: error: not UTF-8 text (byte 55), 0xe9 cannot be decoded")
