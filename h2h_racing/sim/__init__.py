"""The batched simulation core: ``RaceCore`` (E env copies x N cars in arrays), its state,
starts, penalties and events, the race rules, physics (the only pymunk importer), tyre
dynamics, bot cars, re-placement and the built-in reward. It imports only ``track``,
``config`` and ``common``.
"""
