"""Constants of the file formats: number formatting, tolerances of readers, OBJ frames."""

# --- readers ----------------------------------------------------------------------
# Limits that bound what a reader holds (docs/errors.md, "Limits"): a longer line
# stops the reading at once with exit 2 at file:line.
MAX_LINE_BYTES = 1_000_000          # .lsys lines, tree-file records, wind keyframe rows
# An angle CSV row holds 2 B + 1 numbers of up to ~17 characters: this cap allows
# ~2.9 M branches (more than --max-modules lets a tree have).
MAX_CSV_LINE_BYTES = 100_000_000
MAX_JSON_DEPTH = 8                  # nesting of arrays/objects in one tree-file record
READ_CHUNK_BYTES = 1 << 20          # read inputs a MiB at a time
MAX_TEXT_BYTES = 2 << 30            # a text input in all (as MAX_NPZ_BYTES for archives): an endless
                                    # pipe or /dev/urandom is refused, not held until memory runs out
# .npz archives: every member's declared shape and uncompressed size is checked against
# these before anything is decompressed (a 390,625-branch tree is about 90 MB; a zip bomb
# of a few MB can declare gigabytes).
MAX_NPZ_BYTES = 2 << 30             # the archive file, and all its members uncompressed (2 GiB)
MAX_NPZ_MEMBERS = 64                # arrays in one archive (a tree has 20)
ZIP_MAGIC = b"PK\x03\x04"           # a zip archive's first bytes (an .npz is one): a local file header
ZIP_SIGNATURES = (ZIP_MAGIC, b"PK\x05\x06")   # ... or the end record of an empty archive
NORMAL_UNIT_TOL = 1e-6        # tree files: leaf normals must be unit length within this
DERIVED_TEXT_CHUNK_MODULES = 1 << 18  # modules per chunk of `derive --format string`

# --- output formatting ------------------------------------------------------------
# Angles and other floats in CSV output: fixed significant digits, so that a
# last-bit difference in a libm routine on another machine does not change bytes.
CSV_FLOAT_FORMAT = "%.10g"
CSV_BLOCK_VALUES = 1 << 20    # an angle CSV is read into numpy blocks of about this many values
JSON_SIGNIFICANT_DIGITS = 10  # compare --json rounds floats to this many digits
TABLE_FLOAT_FORMAT = "%.4g"   # compare's table
# Tree files store floats exactly (shortest repr round-trips), so that
# `derive | simulate -` and `simulate x.lsys` see identical numbers.
AXIOM_LINE_CHARS = 10_000          # a longer axiom is written on indented lines of this length
