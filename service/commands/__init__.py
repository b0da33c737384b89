"""One module per ``gaitwatch`` sub-command; each defines ``register(subparsers)``.

A registered sub-command sets ``func`` (taking the parsed ``argparse.Namespace`` and returning an
exit code) with ``parser.set_defaults(func=...)``.
"""
