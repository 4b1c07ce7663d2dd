"""Constants of animation out: OBJ frames (and the glTF/USD exporters)."""

# --- OBJ frames (export/obj.py) ---------------------------------------------------------
OBJ_SIDES = 8                 # sides of a branch tube
OBJ_TIP_TAPER = 0.7           # top radius / radius, for a branch without children
OBJ_LAYOUT_MARGIN = 0.25      # gap between trees side by side, x the tallest rest height
OBJ_DIGITS = 6                # decimals of OBJ coordinates (micrometres)
GLTF_CYLINDER_SIDES = 8        # sides of a branch tube in glTF
MAX_USD_DEPTH = 2_000            # branches in a chain, root to tip, of an OpenUSD export: a prim
                                # per branch nests in its parent's, so the file (and the prim
                                # paths) grow with the square of the depth (4,000: 579 MB of .usda)
MAX_EXPORT_SAMPLES = 10_000_000  # frames x branches of one export: the poses, rotations and
                                 # quaternions computed for it peak near 460 bytes each (4.6 GB
                                 # here; 500,000,000 let a run exhaust the machine's memory)

# --- the view page (export/view.py) ---------------------------------------------------------
VIEW_TITLE = "plantlod: original and levels side by side"
VIEW_MAX_FILE_BYTES = 1 << 30  # a .glb / .gltf given to view (the page carries it whole)

# glTF stores keyframe times as float32: a run past float32's largest finite value (the same
# bound for OpenUSD's time codes, so both formats refuse it alike) has no frame time to write
GLTF_MAX_TIME = 3.4028234663852886e38
