"""A plant Context for a LeafSystem's own calculations, kept in the system's cache.

Not on ``self``: a Context there would be shared by every clone of the diagram's
Context (docs/design.md §5). The cache gives each Context of the system its own.
"""

from pydrake.common.value import AbstractValue
from pydrake.systems.framework import ValueProducer


def declare_plant_scratch(system, plant):
    """Declares the cache entry on ``system``; returns a function context → scratch plant Context."""
    entry = system.DeclareCacheEntry(
        "plant_context",
        ValueProducer(allocate=lambda: AbstractValue.Make(plant.CreateDefaultContext()),
                      calc=lambda context, value: None),
        prerequisites_of_calc={system.nothing_ticket()})
    return lambda context: entry.get_mutable_cache_entry_value(context).GetMutableValueOrThrow()
