"""Data shipped inside the package, read through :mod:`importlib.resources`.

``characters/`` holds the shipped character files (``<id>.toml``), the shared
gait tables (``gaits.toml``) and each character's clip database
(``<id>/clips/manifest.toml`` with its BVH clips). Code finds the folder with
:func:`quadsim.skeleton.character.characters_dir`; a user's own character
files and clip folders are plain paths and need not be here.
"""
