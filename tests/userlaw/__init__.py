"""A user's own control law, as the README's "Bring your own controller" shows it (importable as
``userlaw`` with ``tests/`` on the path; ``tests/control/test_user_law.py`` runs it)."""
