"""Movement models: pure NumPy/SciPy, no simulator, no device I/O."""
