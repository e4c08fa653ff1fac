"""Flexure models behind one interface (``base.FlexureModel``): ``scm`` (and ``cc``, one mode),
``prb``, ``fem``; ``registry.build_model`` builds one from a flexure's ModelSpec. ``exact`` is the
whole-scene elastica reference solver (``exact.solve_exact``), not a per-flexure model."""
