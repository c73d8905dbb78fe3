"""A named setting's values are declared once (``core.scene.CHOICES``): the formulas and
kernels that implement them know exactly those names."""

from bo2_lighting.addon.core import kernels
from bo2_lighting.addon.core.formulas import brdf, env_brdf
from bo2_lighting.addon.core.lighting import probes
from bo2_lighting.addon.core.scene import CHOICES, RenderSettings


def ids(setting):
    return [c.id for c in CHOICES[setting]]


def test_every_choice_is_implemented_and_every_implementation_offered():
    kernels.load()
    from bo2_lighting.addon.core.kernels import indirect, shading

    assert ids("specular_model") == list(brdf.MODELS) == list(shading.MODELS)
    assert set(ids("env_brdf")) == set(indirect.ENV_MODELS) == set(env_brdf.MODELS) - {"truth"}
    assert ids("normalization") == list(probes.NORMALIZATIONS) == list(indirect.NORMALIZATIONS)
    assert ids("prefilter") == list(probes.PREFILTERS)
    defaults = RenderSettings()
    for setting in CHOICES:
        assert getattr(defaults, setting) in ids(setting)
        assert all(c.label and c.description for c in CHOICES[setting])
