"""Controllers that only see a Plant and a kinematic model."""
