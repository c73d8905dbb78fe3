"""What the core needs of the machine it runs on: its memory and the process's limit on it, in
words (``machine``), and the bounded caches that keep work between renders (``cache``).
"""
