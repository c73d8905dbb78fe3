"""What the bakes and exports write to disk and read back: probe and lightmap files (multi-part
OpenEXR), environment images, and the probes exported for game engines.
"""
