"""One module per `flexgen` subcommand. Each has ``register(subparsers)``, which adds its parser
and sets ``run(args) -> exit code``. ``flexgen/cli.py`` lists them in ``COMMANDS``."""
