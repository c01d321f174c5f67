"""Real devices behind the Plant protocol."""
