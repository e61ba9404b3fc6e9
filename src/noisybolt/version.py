"""noisybolt's version, in a module of its own: a layer that records it (the DFA cache's
headers) reads it here, not through the package facade that imports every layer."""

__version__ = "0.1.0"
