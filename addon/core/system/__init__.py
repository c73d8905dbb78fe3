"""What the core needs of the machine it runs on: its memory and the process's limit on it, in
words (``machine``), the bounded caches that keep work between renders (``cache``), and files
written whole or not at all (``atomic``).
"""
