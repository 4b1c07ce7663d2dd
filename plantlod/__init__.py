"""plantlod: wind-blown L-system trees with levels of detail.

The public Python API lives here (docs/api.md). The subpackages each own one
responsibility and import one way, bottom to top:

    lsys (language) -> sim (dynamics) -> simplify (levels of detail)
        -> scene (many trees, camera-chosen levels) / export (glTF, USD, pages) -> cli

`formats` reads and writes bytes and depends on no domain logic above `lsys`.
"""

from importlib.metadata import PackageNotFoundError, version as _version

try:
    __version__ = _version("plantlod")
except PackageNotFoundError:  # running from a source tree that was never installed
    __version__ = "0+unknown"
