"""AxiDraw pen plotters: the EiBotBoard (EBB) firmware's serial commands, the driver, the plant
and a protocol-accurate emulator on a pseudo-terminal."""
