"""The `heft` subcommands that need more than a few lines, one module each (``add_arguments``, ``run``)."""
