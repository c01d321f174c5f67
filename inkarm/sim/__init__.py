"""MuJoCo simulation: the arm, the pen, the paper and the ink."""
