"""One module per `inkarm` sub-command; each defines ``add_parser(subparsers)`` and ``run(args) -> int``."""
