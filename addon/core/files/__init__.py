"""What the project writes to disk and reads back, every file written whole
(``system.atomic``): OpenEXR files (``exr``), bake files (``bake_file``: probes in
``probe_file``, lightmaps in ``lightmap_file``), environment images (``environment_files``),
cube maps as GPUs store them (``gpu_textures``: DDS, KTX2) and the probes exported for game
engines (``engine_export``).
"""
