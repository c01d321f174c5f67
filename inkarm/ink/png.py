"""Darkness in [0, 1] to the 8-bit grey levels of canvas.png (black ink on white)."""

from __future__ import annotations

import numpy as np

from inkarm.errors import InputError

# Rows of the page converted at a time by png_pixels (a few MB of temporaries).
_PNG_ROWS = 256

# Grey level of each of 256 darkness bins: matplotlib's "gray_r" lookup table, 1 - i / 255,
# scaled by 255 and truncated to 8 bits as its colormaps do (so some levels are one below
# 255 - i). Kept bit for bit so that PNGs match the ones matplotlib's imsave used to write.
_GREY_LEVELS = np.trunc((1.0 - np.linspace(0.0, 1.0, 256)) * 255.0).astype(np.uint8)


def png_pixels(image) -> np.ndarray:
    """8-bit grey levels (rows, cols) of a darkness image in [0, 1]: white (255) where blank
    and black (0) where fully inked. Darkness d falls in bin floor(256 d) (d = 1 in the last),
    whose grey level is ``_GREY_LEVELS``; values outside [0, 1] are clipped, NaN reads as
    blank. These are the
    R = G = B of ``matplotlib.image.imsave(..., cmap="gray_r", vmin=0, vmax=1)``.

    Converted :data:`_PNG_ROWS` rows at a time, so that besides the result (one byte per
    pixel) only a few MB of temporaries are allocated, whatever the page."""
    image = np.asarray(image)
    if image.ndim != 2:
        raise InputError(f"png_pixels: expected a 2-D darkness image, got shape {image.shape}")
    # float32 stays float32: clipping and scaling by 256 are exact in either precision
    dtype = image.dtype if image.dtype in (np.float32, np.float64) else np.float64
    grey = np.empty(image.shape, np.uint8)
    for r0 in range(0, image.shape[0], _PNG_ROWS):
        darkness = np.fmax(np.asarray(image[r0 : r0 + _PNG_ROWS], dtype=dtype), 0.0)  # NaN: 0
        np.minimum(darkness, 1.0, out=darkness)
        darkness *= 256.0
        np.minimum(darkness, 255.0, out=darkness)
        np.take(_GREY_LEVELS, darkness.astype(np.uint8), out=grey[r0 : r0 + _PNG_ROWS])
    return grey
