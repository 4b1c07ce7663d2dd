"""Checks of a glTF given to `plantlod view`, so that a page is made only of a whole file.

Two layers, both before the page is written:

- `check_glb_container`: the GLB header's declared length is the file's, and every chunk
  lies within it (a truncated .glb is refused here);
- `check_document`: every index a glTF object holds points at an object that exists, and
  every accessor and buffer view lies within the bytes it declares (glTF 2.0, section 3.6),
  with the JSON's values of the types the specification gives.

Each failure is an `InputError` naming the file and saying what is wrong where.
"""

from __future__ import annotations

import os
import stat
import struct
import urllib.parse

from plantlod.lsys.errors import InputError

GLB_MAGIC = b"glTF"
GLB_JSON_CHUNK = 0x4E4F534A
GLB_BIN_CHUNK = 0x004E4942
COMPONENT_BYTES = {5120: 1, 5121: 1, 5122: 2, 5123: 2, 5125: 4, 5126: 4}
TYPE_COMPONENTS = {"SCALAR": 1, "VEC2": 2, "VEC3": 3, "VEC4": 4, "MAT2": 4, "MAT3": 9, "MAT4": 16}
TOP_LEVEL_ARRAYS = ("accessors", "animations", "buffers", "bufferViews", "cameras", "images",
                    "materials", "meshes", "nodes", "samplers", "scenes", "skins", "textures")
ANIMATION_PATHS = ("translation", "rotation", "scale", "weights")   # glTF 2.0 channel targets


def check_glb_container(data: bytes, path: str) -> bool:
    """Refuse a GLB whose header or chunks do not match the file's bytes; whether it holds a
    binary chunk (`check_glb_buffer` then holds buffer 0 to it)."""
    if data[:4] != GLB_MAGIC:
        raise InputError("not a glTF file (a .glb starts with 'glTF')", path)
    if len(data) < 12:
        raise InputError(f"not a glTF file: a GLB is at least 12 bytes, this one has "
                         f"{len(data)} (truncated)", path)
    _, version, length = struct.unpack_from("<4sII", data, 0)
    if version != 2:
        raise InputError(f"GLB version {version}; expected glTF 2.0", path)
    if length != len(data):
        raise InputError(f"the GLB header declares {length:,} bytes but the file has "
                         f"{len(data):,} ({'truncated' if length > len(data) else 'extra bytes'})",
                         path)
    at, kinds = 12, []
    while at < len(data):
        if at + 8 > len(data):
            raise InputError(f"a GLB chunk header at byte {at:,} runs past the end of the file",
                             path)
        size, kind = struct.unpack_from("<II", data, at)
        if at + 8 + size > len(data):
            raise InputError(f"the GLB chunk at byte {at:,} declares {size:,} bytes but the file "
                             f"ends {len(data) - at - 8:,} bytes later (truncated?)", path)
        kinds.append(kind)
        at += 8 + size
    if not kinds or kinds[0] != GLB_JSON_CHUNK:
        raise InputError("the GLB's first chunk is not its JSON", path)
    if kinds.count(GLB_BIN_CHUNK) > 1 or (GLB_BIN_CHUNK in kinds and kinds[1] != GLB_BIN_CHUNK):
        raise InputError("a GLB has at most one binary chunk, right after the JSON", path)
    return GLB_BIN_CHUNK in kinds


def check_glb_buffer(doc, path: str) -> None:
    """A GLB's binary chunk is buffer 0's bytes only where buffer 0 has no uri (glTF 2.0,
    "GLB-stored Buffer"). One with both was read from the chunk and written from its uri (an
    empty data: URI made a page whose buffer held 0 of 8,772 bytes: a fuzzer's find,
    session 42)."""
    buffers = doc.buffers if isinstance(doc.buffers, list) else []
    if buffers and getattr(buffers[0], "uri", None) is not None:
        raise InputError("buffers[0] has a uri, but the GLB's binary chunk can only be buffer "
                         "0's bytes where it has none (glTF 2.0); expected one or the other", path)


def buffer_files(path: str, max_bytes: int) -> list[str]:
    """The files beside the glTF (or GLB) at ``path`` that its buffers name, by path (what a
    page written over one would destroy: `plantlod view -o x.bin` replaced the .gltf's own
    buffer). Best effort: [] where the file cannot be read as glTF JSON (its reader says why)."""
    import json

    try:
        info = os.stat(path)
        if not stat.S_ISREG(info.st_mode) or info.st_size > max_bytes:
            return []                        # (a FIFO would wait, a large file is refused:
                                             # its reader says, before reading it)
        with open(path, "rb") as f:
            text = _json_part(f, max_bytes)
        doc = json.loads(text.decode("utf-8")) if text is not None else None
    except (OSError, ValueError, RecursionError):
        return []
    buffers = doc.get("buffers") if isinstance(doc, dict) else None
    out = []
    for buffer in buffers if isinstance(buffers, list) else []:
        uri = buffer.get("uri") if isinstance(buffer, dict) else None
        try:
            local = isinstance(uri, str) and uri and not urllib.parse.urlsplit(uri).scheme
        except ValueError:                   # ("//[x": an invalid IPv6 host; its reader says)
            continue
        if local:
            out.append(os.path.join(os.path.dirname(os.path.abspath(path)),
                                    urllib.parse.unquote(uri)))
    return out


def _json_part(handle, max_bytes: int) -> bytes | None:
    """The JSON text of the glTF or GLB open in ``handle``, reading no more than it needs (a
    GLB's header and JSON chunk; a .gltf whole, if it starts as JSON does: one that starts
    otherwise, a byte-order mark included, `view` refuses before writing); None otherwise."""
    start = handle.read(20)
    if start[:4] == GLB_MAGIC:
        if len(start) < 20:
            return None
        return gltf_json(start + handle.read(min(struct.unpack_from("<I", start, 12)[0],
                                                  max_bytes)))
    if start.lstrip()[:1] not in (b"{", b""):  # (blanks first: read on)
        return None
    return start + handle.read(max_bytes + 1 - len(start))


def check_buffer_uris(doc, path: str, max_bytes: int) -> None:
    """Before any buffer is read: at most one buffer; a buffer in another file must be a
    regular file beside ``path`` (a relative URI, no scheme) of at most ``max_bytes``."""
    buffers = doc.buffers if isinstance(doc.buffers, list) else []
    if len(buffers) > 1:
        raise InputError(f"the file has {len(buffers)} buffers; plantlod view carries glTF "
                         "with one (as `plantlod export` writes)", path)
    for buffer in buffers:
        uri = getattr(buffer, "uri", None)
        if uri is None or (isinstance(uri, str) and uri.startswith("data:")):
            continue
        try:
            scheme = urllib.parse.urlsplit(uri).scheme if isinstance(uri, str) else None
        except ValueError:                   # ("//[x": an invalid IPv6 host)
            scheme = "?"
        if not isinstance(uri, str) or not uri or scheme:
            raise InputError(f"buffer URI {str(uri)[:80]!r}: expected a data: URI or the name "
                             "of a file beside the glTF", path)
        name = urllib.parse.unquote(uri)
        if "/" in name or "\\" in name or "\0" in name or name in (".", ".."):
            raise InputError(f"buffer URI {uri[:80]!r}: expected the name of a file beside the "
                             "glTF (no folder, no NUL byte)", path)
        folder = os.path.dirname(os.path.abspath(path))
        target = os.path.join(folder, name)
        if os.path.dirname(os.path.realpath(target)) != os.path.realpath(folder):
            raise InputError(f"buffer file {uri[:80]!r} is a link out of the glTF's folder; "
                             "expected a file beside the glTF", path)
        try:
            info = os.stat(target)
        except OSError as exc:
            raise InputError(f"buffer file {uri[:80]!r}: {exc.strerror or exc}", path) from None
        if not stat.S_ISREG(info.st_mode):
            raise InputError(f"buffer file {uri[:80]!r} is not a regular file", path)
        if info.st_size > max_bytes:
            raise InputError(f"buffer file {uri[:80]!r} has {info.st_size:,} bytes, more than "
                             f"the limit of {max_bytes:,}", path)


class _Checker:
    """Index and length checks of one document; ``fail`` raises the InputError."""

    def __init__(self, doc, path: str):
        self.doc, self.path = doc, path
        self._checked: dict[str, list] = {}      # each list checked once (`items`)

    def fail(self, message: str):
        raise InputError(message, self.path)

    def items(self, name: str) -> list:
        """The document's list ``name`` ([] where absent), each entry an object. Checked once
        and kept: `index` asks for it at every reference, and a check per call made
        `view` quadratic in the nodes (abop_1_25's 3,891 branches: 28 s)."""
        if name not in self._checked:
            self._checked[name] = self._items(name)
        return self._checked[name]

    def _items(self, name: str) -> list:
        value = getattr(self.doc, name, None)
        if value is None:
            return []
        if not isinstance(value, list):
            self.fail(f"'{name}' must be a list")
        return self.objects(value, name)

    def objects(self, values: list, what: str) -> list:
        """``values``, each an object (a JSON null or number in a list of glTF objects was
        an internal error when its members were read)."""
        for k, value in enumerate(values):
            if value is None or isinstance(value, (bool, int, float, str, list, dict)):
                self.fail(f"{what}[{k}] is {_json(value)}; expected an object")
        return values

    def count(self, value, what: str, default: int | None = None) -> int:
        if value is None and default is not None:
            return default
        if not isinstance(value, int) or isinstance(value, bool) or value < 0:
            self.fail(f"{what} must be a whole number >= 0, got {value!r}")
        return value

    def index(self, value, name: str, what: str, optional: bool = False) -> int | None:
        if value is None and optional:
            return None
        n = len(self.items(name))
        if not isinstance(value, int) or isinstance(value, bool) or not 0 <= value < n:
            self.fail(f"{what} is {value!r}; expected an index of '{name}' (0..{n - 1})"
                      if n else f"{what} is {value!r} but the file has no '{name}'")
        return value


def check_document(doc, blob_length: int, path: str) -> None:
    """Refuse a document whose indices or byte ranges point outside what it holds.

    ``blob_length``: the bytes of its one binary buffer (after external and data-URI buffers
    were folded in), which buffer 0 may not declare more of."""
    c = _Checker(doc, path)
    for name in TOP_LEVEL_ARRAYS:                 # every element an object, used or not
        c.items(name)
    buffers = c.items("buffers")
    for i, buffer in enumerate(buffers):
        size = c.count(getattr(buffer, "byteLength", None), f"buffers[{i}].byteLength")
        if i == 0 and size > blob_length:
            c.fail(f"buffers[0] declares {size:,} bytes but holds {blob_length:,} (truncated?)")
    views = c.items("bufferViews")
    for i, view in enumerate(views):
        b = c.index(view.buffer, "buffers", f"bufferViews[{i}].buffer")
        offset = c.count(view.byteOffset, f"bufferViews[{i}].byteOffset", 0)
        size = c.count(view.byteLength, f"bufferViews[{i}].byteLength")
        if offset + size > buffers[b].byteLength:
            c.fail(f"bufferViews[{i}] spans bytes {offset:,}..{offset + size:,} of buffer {b}, "
                   f"which has {buffers[b].byteLength:,}")
        if view.byteStride is not None:
            stride = c.count(view.byteStride, f"bufferViews[{i}].byteStride")
            if not 4 <= stride <= 252:
                c.fail(f"bufferViews[{i}].byteStride is {stride}; expected 4..252")
    for i, acc in enumerate(c.items("accessors")):
        _check_accessor(c, i, acc, views)
    _check_meshes(c)
    _check_nodes(c)
    _check_references(c)
    for i, anim in enumerate(c.items("animations")):
        samplers = anim.samplers if isinstance(anim.samplers, list) else c.fail(
            f"animations[{i}].samplers must be a list")
        c.objects(samplers, f"animations[{i}].samplers")
        channels = c.objects(anim.channels if isinstance(anim.channels, list) else [],
                             f"animations[{i}].channels")   # (a list: `check_raw_json`)
        for j, sampler in enumerate(samplers):
            c.index(sampler.input, "accessors", f"animations[{i}].samplers[{j}].input")
            c.index(sampler.output, "accessors", f"animations[{i}].samplers[{j}].output")
        for j, channel in enumerate(channels):
            if (not isinstance(channel.sampler, int) or isinstance(channel.sampler, bool)
                    or not 0 <= channel.sampler < len(samplers)):
                c.fail(f"animations[{i}].channels[{j}].sampler is {channel.sampler!r}; expected "
                       f"0..{len(samplers) - 1}")
            target = channel.target
            if target is None:
                c.fail(f"animations[{i}].channels[{j}] has no target")
            c.index(target.node, "nodes", f"animations[{i}].channels[{j}].target.node",
                    optional=True)
            if target.path not in ANIMATION_PATHS:
                c.fail(f"animations[{i}].channels[{j}].target.path is {target.path!r}; expected "
                       f"one of {', '.join(ANIMATION_PATHS)}")


def check_animation_data(doc, blob: bytes, path: str) -> None:
    """Refuse key times that are not finite or not strictly increasing and animated values
    that are not finite (glTF 2.0, 3.11; a page's loader logged errors or played nothing).
    Reads each sampler's float accessors from ``blob``, the document's one buffer, after
    `check_document` found their byte ranges inside it (sparse accessors are not read)."""
    import numpy as np

    def fail(message: str):
        raise InputError(message, path)

    # (lists `check_document` checked: read once more from the document, not checked again)
    accessors, views = doc.accessors or [], doc.bufferViews or []

    def floats(k: int):
        acc = accessors[k]
        if acc.componentType != 5126 or acc.bufferView is None or acc.sparse is not None:
            return None
        view = views[acc.bufferView]
        width = TYPE_COMPONENTS[acc.type]
        start = (view.byteOffset or 0) + (acc.byteOffset or 0)
        return np.ndarray((acc.count, width), dtype="<f4", buffer=blob, offset=start,
                          strides=(view.byteStride or 4 * width, 4))

    for i, anim in enumerate(doc.animations or []):
        for j, sampler in enumerate(anim.samplers):
            what = f"animations[{i}].samplers[{j}]"
            times = floats(sampler.input)
            if times is not None and len(times):
                t = times[:, 0].astype(np.float64)
                if not np.all(np.isfinite(t)):
                    fail(f"{what}: key time {int(np.argmin(np.isfinite(t)))} is not finite")
                if np.any(np.diff(t) <= 0):
                    k = int(np.argmax(np.diff(t) <= 0)) + 1
                    fail(f"{what}: key time {k} ({t[k]:g} s) is not after the one before "
                           f"({t[k - 1]:g} s); expected strictly increasing times")
            values = floats(sampler.output)
            if values is not None and not np.all(np.isfinite(values)):
                row = int(np.argmin(np.isfinite(values).all(axis=1)))
                fail(f"{what}: output value {row} is not finite")


def _check_references(c: _Checker) -> None:
    """The indices a page's loader follows beyond meshes, nodes and animations: a node's skin
    and camera, a skin's joints and matrices, a texture's image and sampler, an image's
    buffer view, a material's textures, a sparse accessor's views (a dangling one made a
    page that failed in the browser; a morph target's accessors: `_check_meshes`)."""
    for i, node in enumerate(c.items("nodes")):
        c.index(node.skin, "skins", f"nodes[{i}].skin", optional=True)
        c.index(node.camera, "cameras", f"nodes[{i}].camera", optional=True)
    for i, skin in enumerate(c.items("skins")):
        c.index(skin.inverseBindMatrices, "accessors", f"skins[{i}].inverseBindMatrices",
                optional=True)
        c.index(skin.skeleton, "nodes", f"skins[{i}].skeleton", optional=True)
        for joint in _listed(c, skin.joints, f"skins[{i}].joints"):
            c.index(joint, "nodes", f"skins[{i}].joints")
    for i, texture in enumerate(c.items("textures")):
        c.index(texture.source, "images", f"textures[{i}].source", optional=True)
        c.index(texture.sampler, "samplers", f"textures[{i}].sampler", optional=True)
    for i, image in enumerate(c.items("images")):
        c.index(image.bufferView, "bufferViews", f"images[{i}].bufferView", optional=True)
    for i, material in enumerate(c.items("materials")):
        pbr = material.pbrMetallicRoughness
        refs = [("normalTexture", material.normalTexture),
                ("occlusionTexture", material.occlusionTexture),
                ("emissiveTexture", material.emissiveTexture)]
        if pbr is not None:
            refs += [("pbrMetallicRoughness.baseColorTexture", pbr.baseColorTexture),
                     ("pbrMetallicRoughness.metallicRoughnessTexture",
                      pbr.metallicRoughnessTexture)]
        for name, ref in refs:
            if ref is not None:
                c.index(ref.index, "textures", f"materials[{i}].{name}.index")
    for i, acc in enumerate(c.items("accessors")):
        sparse = acc.sparse
        if sparse is not None:
            for part in ("indices", "values"):
                ref = getattr(sparse, part, None)
                if ref is None:
                    c.fail(f"accessors[{i}].sparse has no {part}")
                c.index(ref.bufferView, "bufferViews", f"accessors[{i}].sparse.{part}.bufferView")


def _json(value) -> str:
    """A JSON value as the file writes it, shortened (null, true, 5, "x")."""
    import json
    try:
        text = json.dumps(value)
    except (TypeError, ValueError):
        text = repr(value)
    return text if len(text) <= 40 else text[:37] + "..."


def _listed(c: _Checker, value, what: str) -> list:
    """``value`` where it is a list, [] where it is absent."""
    if value is None:
        return []
    if not isinstance(value, list):
        c.fail(f"{what} must be a list")
    return value


def _check_accessor(c: _Checker, i: int, acc, views: list) -> None:
    what = f"accessors[{i}]"
    if acc.componentType not in COMPONENT_BYTES:
        c.fail(f"{what}.componentType is {acc.componentType!r}; expected one of "
               f"{sorted(COMPONENT_BYTES)}")
    if acc.type not in TYPE_COMPONENTS:
        c.fail(f"{what}.type is {acc.type!r}; expected one of {', '.join(TYPE_COMPONENTS)}")
    count = c.count(acc.count, f"{what}.count")
    offset = c.count(acc.byteOffset, f"{what}.byteOffset", 0)
    if acc.bufferView is None:
        return
    v = c.index(acc.bufferView, "bufferViews", f"{what}.bufferView")
    element = COMPONENT_BYTES[acc.componentType] * TYPE_COMPONENTS[acc.type]
    stride = views[v].byteStride or element
    need = offset + stride * (count - 1) + element if count else offset
    if need > views[v].byteLength:
        c.fail(f"{what} needs {need:,} bytes of bufferViews[{v}], which has "
               f"{views[v].byteLength:,}")


def _check_meshes(c: _Checker) -> None:
    for i, mesh in enumerate(c.items("meshes")):
        primitives = mesh.primitives if isinstance(mesh.primitives, list) else c.fail(
            f"meshes[{i}].primitives must be a list")
        c.objects(primitives, f"meshes[{i}].primitives")
        for j, prim in enumerate(primitives):
            what = f"meshes[{i}].primitives[{j}]"
            _check_attributes(c, prim.attributes, f"{what}.attributes")
            for k, target in enumerate(_listed(c, prim.targets, f"{what}.targets")):
                _check_attributes(c, target, f"{what}.targets[{k}]")      # morph targets
            c.index(prim.indices, "accessors", f"{what}.indices", optional=True)
            c.index(prim.material, "materials", f"{what}.material", optional=True)


def _check_attributes(c: _Checker, attributes, what: str) -> None:
    """An attribute map (name -> accessor index) whose every index is an accessor."""
    values = (vars(attributes) if hasattr(attributes, "__dict__")
              else attributes if isinstance(attributes, dict) else c.fail(
                  f"{what} must be an object"))
    for name, value in values.items():
        if value is not None:
            c.index(value, "accessors", f"{what}.{name}")


def _check_nodes(c: _Checker) -> None:
    nodes = c.items("nodes")
    parent: dict[int, int] = {}
    for i, node in enumerate(nodes):
        c.index(node.mesh, "meshes", f"nodes[{i}].mesh", optional=True)
        children = node.children if node.children is not None else []
        if not isinstance(children, list):
            c.fail(f"nodes[{i}].children must be a list")
        for child in children:
            c.index(child, "nodes", f"nodes[{i}].children")
            if child in parent or child == i:
                c.fail(f"node {child} has more than one parent (nodes[{i}].children); the "
                       "nodes must form trees")
            parent[child] = i
    # each node has at most one parent: a cycle is exactly a node no root reaches
    reached, todo = 0, [i for i in range(len(nodes)) if i not in parent]
    while todo:
        i = todo.pop()
        reached += 1
        todo.extend(nodes[i].children or [])
    if reached != len(nodes):
        c.fail("some nodes are their own ancestors; the nodes must form trees")
    # a scene's nodes are roots, each once: a child listed as a root (drawn twice, once
    # without its parent's motion) or a root listed twice is no tree
    for i, scene in enumerate(c.items("scenes")):
        seen = set()
        for node in scene.nodes or []:
            c.index(node, "nodes", f"scenes[{i}].nodes")
            if node in parent:
                c.fail(f"scenes[{i}].nodes lists node {node}, which is another node's child; "
                       "expected the roots of the node trees")
            if node in seen:
                c.fail(f"scenes[{i}].nodes lists node {node} twice")
            seen.add(node)
    c.index(getattr(c.doc, "scene", None), "scenes", "scene", optional=True)


def gltf_json(data: bytes) -> bytes | None:
    """The JSON text of a .gltf file's bytes or of a GLB's first chunk (None: neither)."""
    if data[:4] == GLB_MAGIC:
        if len(data) < 20:
            return None
        size = struct.unpack_from("<I", data, 12)[0]
        return data[20:20 + size]
    return data


def check_raw_json(data: bytes, path: str) -> None:
    """What the glTF reader (pygltflib) would change before `check_document` sees it: JSON's
    NaN and Infinity (not JSON; "cannot convert float NaN to integer" before), and values of
    the wrong JSON type it casts (an accessor count of 1.5 read as 1, "3" as 3). Checked on
    the file's own JSON: counts, offsets, lengths and strides whole numbers; a node's
    rotation 4 numbers, translation and scale 3, matrix 16; a primitive's mode 0..6; an
    animation's channels and samplers lists, a sampler's interpolation LINEAR, STEP or
    CUBICSPLINE and its input a SCALAR of floats; every object's name a string (glTF 2.0,
    3.6-3.11). Text that is not JSON is left to the reader."""
    import json

    text = gltf_json(data)
    if text is None:
        return

    def constant(name: str):
        raise InputError(f"the glTF's JSON holds {name}, which JSON has no number for", path)

    try:
        doc = json.loads(text.decode("utf-8-sig"), parse_constant=constant)
    except (ValueError, RecursionError):
        return
    if not isinstance(doc, dict):
        return
    c = _Checker(None, path)

    def listed(name: str) -> list:
        value = doc.get(name)
        return [v if isinstance(v, dict) else {} for v in value] if isinstance(value, list) else []

    def whole(value, what: str) -> None:
        if value is not None and (not isinstance(value, int) or isinstance(value, bool)):
            c.fail(f"{what} is {_json(value)}; expected a whole number")

    def numbers(value, size: int, what: str) -> None:
        if value is not None and not (isinstance(value, list) and len(value) == size and all(
                isinstance(x, (int, float)) and not isinstance(x, bool) for x in value)):
            c.fail(f"{what} is {_json(value)}; expected {size} numbers")

    def present(table: dict, key: str, what: str):
        """``table[key]``, refused where the file writes null (glTF has no null property:
        the reader took it for an absent one, which a page's loader refuses)."""
        if key in table and table[key] is None:
            c.fail(f"{what} is null; expected it left out or a value")
        return table.get(key)

    asset = doc.get("asset")
    version = asset.get("version") if isinstance(asset, dict) else None
    if not (isinstance(version, str) and version.split(".")[0] == "2"):
        c.fail(f"asset.version is {_json(version)}; expected \"2.0\" (glTF 2.0)"
               if isinstance(asset, dict) else "the glTF has no asset; expected "
               "{\"asset\": {\"version\": \"2.0\"}}")
    for name in TOP_LEVEL_ARRAYS:     # a name where given is a string (the reader cast 5 to
        for k, item in enumerate(listed(name)):   # "5" and kept {"a": 1}, on which a page's
            label = item.get("name")              # loader calls string methods)
            if label is not None and not isinstance(label, str):
                c.fail(f"{name}[{k}].name is {_json(label)}; expected a string")
    for i, anim in enumerate(listed("animations")):   # (the reader took {} for no channels)
        for key in ("channels", "samplers"):
            if not isinstance(anim.get(key), list):
                c.fail(f"animations[{i}].{key} is {_json(anim.get(key))}; expected a list "
                       "(glTF 2.0 requires it)" if key in anim else
                       f"animations[{i}] has no {key}; expected a list (glTF 2.0 requires it)")
    for i, buffer in enumerate(listed("buffers")):
        whole(buffer.get("byteLength"), f"buffers[{i}].byteLength")
    for i, view in enumerate(listed("bufferViews")):
        for key in ("buffer", "byteOffset", "byteLength", "byteStride", "target"):
            whole(view.get(key), f"bufferViews[{i}].{key}")
    accessors = listed("accessors")
    for i, acc in enumerate(accessors):
        for key in ("bufferView", "byteOffset", "componentType", "count"):
            whole(present(acc, key, f"accessors[{i}].{key}"), f"accessors[{i}].{key}")
        normalized = acc.get("normalized")
        if normalized is not None and not isinstance(normalized, bool):
            c.fail(f"accessors[{i}].normalized is {_json(normalized)}; expected true or false")
    for i, node in enumerate(listed("nodes")):
        for key, size in (("rotation", 4), ("translation", 3), ("scale", 3), ("matrix", 16)):
            numbers(node.get(key), size, f"nodes[{i}].{key}")
        for key in ("mesh", "skin", "camera"):
            whole(node.get(key), f"nodes[{i}].{key}")
    for i, mesh in enumerate(listed("meshes")):
        prims = mesh.get("primitives")
        for j, prim in enumerate(prims if isinstance(prims, list) else []):
            mode = prim.get("mode") if isinstance(prim, dict) else None
            if mode is not None and (not isinstance(mode, int) or isinstance(mode, bool)
                                     or not 0 <= mode <= 6):
                c.fail(f"meshes[{i}].primitives[{j}].mode is {_json(mode)}; expected 0..6")
    for i, anim in enumerate(listed("animations")):
        samplers = anim.get("samplers")
        for j, sampler in enumerate(samplers if isinstance(samplers, list) else []):
            if not isinstance(sampler, dict):
                continue
            what = f"animations[{i}].samplers[{j}]"
            how = sampler.get("interpolation")
            if how is not None and how not in ("LINEAR", "STEP", "CUBICSPLINE"):
                c.fail(f"{what}.interpolation is {_json(how)}; expected LINEAR, STEP or "
                       "CUBICSPLINE")
            k = sampler.get("input")
            if isinstance(k, int) and not isinstance(k, bool) and 0 <= k < len(accessors):
                acc = accessors[k]
                if acc.get("type") != "SCALAR" or acc.get("componentType") != 5126:
                    c.fail(f"{what}.input is accessors[{k}], a {_json(acc.get('type'))} of "
                           f"componentType {_json(acc.get('componentType'))}; expected a "
                           "SCALAR of floats (5126): the key times")
                if acc.get("count") == 0:
                    c.fail(f"{what}.input is accessors[{k}], which holds no key times; expected "
                           "at least one")
        _check_channel_outputs(c, i, anim, samplers, accessors)


def _check_channel_outputs(c: "_Checker", i: int, anim: dict, samplers, accessors: list) -> None:
    """Each channel's sampler output as its target path needs it (glTF 2.0, 3.11): rotation
    VEC4, translation and scale VEC3, weights SCALAR; one value a key time (LINEAR, STEP),
    three with CUBICSPLINE (in-tangent, value, out-tangent), weights a whole multiple of
    that. A page's loader given fewer values than key times hung (61 times, 30 rotations)."""
    shape = {"rotation": "VEC4", "translation": "VEC3", "scale": "VEC3", "weights": "SCALAR"}
    channels = anim.get("channels")
    for j, channel in enumerate(channels if isinstance(channels, list) else []):
        target = channel.get("target") if isinstance(channel, dict) else None
        k = channel.get("sampler") if isinstance(channel, dict) else None
        if not (isinstance(target, dict) and isinstance(k, int) and isinstance(samplers, list)
                and 0 <= k < len(samplers) and isinstance(samplers[k], dict)):
            continue                          # (check_document names what is missing)
        sampler, path = samplers[k], target.get("path")
        times, values = sampler.get("input"), sampler.get("output")
        if path not in shape or not all(isinstance(a, int) and not isinstance(a, bool)
                                        and 0 <= a < len(accessors) for a in (times, values)):
            continue
        out = accessors[values]
        what = f"animations[{i}].channels[{j}] ({path})"
        if out.get("type") != shape[path]:
            c.fail(f"{what}: its output accessors[{values}] is a {_json(out.get('type'))}; "
                   f"expected a {shape[path]}")
        keys, count = accessors[times].get("count"), out.get("count")
        if not (isinstance(keys, int) and isinstance(count, int)) or keys <= 0:
            continue
        per = 3 if sampler.get("interpolation") == "CUBICSPLINE" else 1
        if (count % (per * keys) != 0 or count == 0) if path == "weights" else count != per * keys:
            c.fail(f"{what}: {keys:,} key times but {count:,} output values; expected "
                   + (f"{per} x {keys:,}" if per > 1 else f"{keys:,}")
                   + (" per morph target" if path == "weights" else ""))
