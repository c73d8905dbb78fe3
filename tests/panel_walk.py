"""What each Properties tab shows an artist: every registered panel of the tab whose poll
accepts the context is drawn into a recording layout (sub-panels only under a shown parent).

Used by the headless Blender tests (a stand-in context) and by the walk-through in a real
window (Blender's own context of the Properties editor).
"""

from __future__ import annotations

import inspect

import bpy


class Recorder:
    """A layout that records what a panel draws: ``("prop", (struct type, property), kwargs)``,
    ``("operator", (idname,), kwargs)``, ``("label", (), kwargs)``, ...; a property that its
    data does not have fails at once."""

    def __init__(self, log):
        object.__setattr__(self, "log", log)

    def __getattr__(self, name):  # layout methods not checked: row(), label(), ...
        if name.startswith("__"):
            raise AttributeError(name)

        def method(*args, **kwargs):
            self.log.append((name, args, kwargs))
            return Recorder(self.log)
        return method

    def __setattr__(self, name, value):  # use_property_split, active, alert, ...
        pass

    def __bool__(self):
        return True

    def prop(self, data, name, **kwargs):
        assert data is not None, f"prop({name!r}) on None"
        if not name.startswith("["):  # custom properties: '["name"]'
            assert name in data.bl_rna.properties, \
                f"{type(data).__name__} has no property {name!r}"
        self.log.append(("prop", (type(data).__name__, name), kwargs))
        return Recorder(self.log)

    def prop_search(self, data, name, search_data, search_name, **kwargs):
        """A setting drawn with a search list: recorded as its ``prop``; the list must exist."""
        assert search_name in search_data.bl_rna.properties, \
            f"{type(search_data).__name__} has no collection {search_name!r}"
        return self.prop(data, name, **kwargs)

    def operator(self, idname, **kwargs):
        module, op = idname.split(".")
        rna = getattr(getattr(bpy.ops, module), op).get_rna_type()
        self.log.append(("operator", (idname,), kwargs))
        return OperatorProps(rna)


class OperatorProps:
    """An operator button's properties: each one set must exist, enum values too."""

    def __init__(self, rna):
        object.__setattr__(self, "rna", rna)

    def __setattr__(self, name, value):
        assert name in self.rna.properties, f"{self.rna.identifier} has no property {name!r}"
        prop = self.rna.properties[name]
        if prop.type == "ENUM":
            assert value in prop.enum_items.keys(), f"{name} = {value!r}"


class PanelProxy:
    """Stands for a panel instance while its class's ``draw`` runs: its layout records."""

    def __init__(self, cls, log):
        self._cls, self.layout = cls, Recorder(log)

    def __getattr__(self, name):
        raw = inspect.getattr_static(self._cls, name)
        if isinstance(raw, (staticmethod, classmethod)):
            return getattr(self._cls, name)
        value = getattr(self._cls, name)
        return value.__get__(self) if inspect.isfunction(value) else value


def properties_panels() -> list[type]:
    """Every registered panel of the Properties editor, in registration order."""
    found, seen = [], set()
    stack = list(bpy.types.Panel.__subclasses__())
    while stack:
        cls = stack.pop(0)
        if cls in seen:
            continue
        seen.add(cls)
        stack.extend(cls.__subclasses__())
        if getattr(cls, "bl_space_type", None) == "PROPERTIES" \
                and getattr(cls, "is_registered", False):
            found.append(cls)
    return found


def _label(cls) -> str:
    label = getattr(cls, "bl_label", "")
    return label or cls.__name__


def shown(context, tab: str) -> list[tuple[type, list]]:
    """(panel class, its log) for every panel that ``context`` shows in Properties tab ``tab``
    (``bl_context``: "render", "data", "material", ...): the top-level panels in the editor's
    order (``bl_order``, then registration), each sub-panel after its parent."""
    out, drawn, refused = [], set(), set()
    panels = sorted((c for c in properties_panels() if getattr(c, "bl_context", "") == tab),
                    key=lambda c: getattr(c, "bl_order", 0))  # as the editor orders them
    pending = True
    while pending:  # parents first, whatever the registration order
        pending = False
        for cls in panels:
            idname = getattr(cls, "bl_idname", cls.__name__)
            if idname in drawn or idname in refused:
                continue
            parent = getattr(cls, "bl_parent_id", "")
            if parent and parent not in drawn:
                continue  # its parent is not shown (yet: a later pass may draw it)
            poll = getattr(cls, "poll", None)
            try:
                accepted = poll is None or bool(poll(context))
            except AttributeError:  # the context lacks what the panel needs: not its tab
                accepted = False
            if not accepted:
                refused.add(idname)
                continue
            log = []
            proxy = PanelProxy(cls, log)
            if hasattr(cls, "draw_header"):
                cls.draw_header(proxy, context)
            if hasattr(cls, "draw"):
                cls.draw(proxy, context)
            out.append((cls, log))
            drawn.add(idname)
            pending = True
    return out


def shown_properties(panels) -> list[str]:
    """Every property the panels draw, as "Struct.property" ("Struct.property[i]" for one
    item of an array), once per time drawn."""
    return [f"{entry[1][0]}.{entry[1][1]}"
            + (f"[{entry[2]['index']}]" if entry[2].get("index", -1) >= 0 else "")
            for _, log in panels for entry in log if entry[0] == "prop"]


def duplicate_titles(panels) -> list[str]:
    """Titles shown by more than one panel of a tab (unlabelled panels aside)."""
    titles = [c.bl_label for c, _ in panels if getattr(c, "bl_label", "")]
    return sorted({t for t in titles if titles.count(t) > 1})
