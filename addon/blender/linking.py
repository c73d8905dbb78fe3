"""Light and shadow linking read from Blender (Object > Shading > Light Linking and Shadow
Linking): each receiver and blocker collection becomes a linking set, each object the mask of
the sets it belongs to (``core.scene.linking``).
"""

from __future__ import annotations

from ..core.scene import linking


def entries(collection) -> tuple[set, set]:
    """The names of the objects a linking collection includes and excludes: its objects by
    their own link state, the objects of its child collections (at any depth) by the child's."""
    included, excluded = set(), set()
    # a collection's ``collection_objects`` and ``collection_children`` hold the link states
    # of its ``objects`` and ``children``, in the same order
    for obj, link in zip(collection.objects, collection.collection_objects, strict=True):
        (included if link.light_linking.link_state == "INCLUDE" else excluded).add(
            obj.original.name_full)
    for child, link in zip(collection.children, collection.collection_children, strict=True):
        (included if link.light_linking.link_state == "INCLUDE" else excluded).update(
            o.original.name_full for o in child.all_objects)
    return included, excluded


class Sets:
    """The linking sets of one scene's lights, numbered as they are met (1, 2, ... per kind;
    lights beyond ``linking.SETS - 1`` collections of a kind stay unlinked, with a warning)."""

    KINDS = ("receiver_collection", "blocker_collection")

    def __init__(self, warnings) -> None:
        self.warnings = warnings
        self.numbers: tuple[dict, dict] = ({}, {})  # collection name -> set
        self.entries: tuple[list, list] = ([], [])  # per set from 1: (included, excluded)

    def of_light(self, obj) -> tuple[int, int]:
        """(receivers, blockers) of light object ``obj``: its collections' set numbers, 0
        where it has none."""
        found = []
        for kind, numbers, entries_ in zip(self.KINDS, self.numbers, self.entries, strict=True):
            collection = getattr(obj.original.light_linking, kind, None)
            if collection is None:
                found.append(0)
                continue
            key = collection.name_full
            if key not in numbers:
                if len(numbers) >= linking.SETS - 1:
                    self.warnings.add(f"Light '{obj.name}': more than {linking.SETS - 1} "
                                      f"light or shadow linking collections; "
                                      f"'{collection.name}' is ignored")
                    found.append(0)
                    continue
                numbers[key] = len(numbers) + 1
                entries_.append(entries(collection))
                if not any(entries_[-1]):
                    self.warnings.add(
                        f"Light '{obj.name}': its {kind.split('_')[0]} collection "
                        f"'{collection.name}' is empty, so every object "
                        + ("receives its light" if kind == self.KINDS[0] else "shadows it")
                        + " (as in Cycles)")
            found.append(numbers[key])
        return found[0], found[1]

    def of_object(self, obj) -> tuple[int, int]:
        """(light_sets, shadow_sets) of object ``obj`` (``MeshBatch``'s fields)."""
        name = obj.original.name_full
        return (linking.mask(name, self.entries[0]), linking.mask(name, self.entries[1]))
