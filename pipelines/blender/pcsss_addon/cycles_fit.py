"""Cycles' Random Walk given a medium (formats/MATERIAL.md#in-cycles-and-renderman):
the base colour whose Cycles albedo is the medium's single-scattering
albedo (Cycles' own fit, inverted by bisection) and the radius `4 pi mfp
/ (1 - g)` (Cycles divides its radius by 4 pi and takes it as the mean
free path over 1 - g). No bpy here: the race's benches import it too.
"""
import math


def cycles_alpha(a, g):
    """The single-scattering albedo Cycles' Random Walk gives a surface
    colour `a` at anisotropy `g` (the fit in Cycles'
    `subsurface_random_walk_remap`, Blender 5.0)."""
    gp = [g ** k for k in range(8)]

    def poly(c):
        return sum(ci * gi for ci, gi in zip(c, gp))

    fa = poly([1.8260523782, -1.28451056436, -1.79904629312, 9.19393289202, -22.8215585862,
               32.0234874259, -23.6264803333, 7.21067002658])
    fb = 4.98511194385 + 0.127355959438 * math.exp(
        poly([0.0, 31.1491581433, -201.847017512, 841.576016723, -2018.09288505, 2731.71560286,
              -1935.41424244, 559.009054474]))
    fc = poly([1.09686102424, -0.394704063468, 1.05258115941, -8.83963712726, 28.8643230661,
               -46.8802913581, 38.5402837518, -12.7181042538])
    fd = poly([0.496310210422, 0.360146581622, -2.15139309747, 17.8896899217, -55.2984010333,
               82.065982243, -58.5106008578, 15.8478295021])
    fe = 4.23190299701 + 0.00310603949088 * math.exp(
        poly([0.0, 76.7316253952, -594.356773233, 2448.8834203, -5576.68528998, 7116.60171912,
              -4763.54467887, 1303.5318055]))
    ff = poly([2.40602999408, -2.51814844609, 9.18494908356, -79.2191708682, 259.082868209,
               -403.613804597, 302.85712436, -87.4370473567])
    blend = a ** 0.25
    alpha = (1 - blend) * fa * math.atan(fb * a) ** fc + blend * fd * math.atan(fe * a) ** ff
    return min(max(alpha, 0.0), 0.999999)


def surface_colour(alpha, g):
    """The colour whose Cycles albedo is `alpha` (bisection)."""
    lo, hi = 0.0, 1.0
    for _ in range(60):
        mid = (lo + hi) / 2
        if cycles_alpha(mid, g) < alpha:
            lo = mid
        else:
            hi = mid
    return (lo + hi) / 2


def medium(albedo, mfp, g):
    """(base colour, radius) per channel for Cycles' Random Walk: the
    medium of single-scattering `albedo` and mean free path `mfp` (per
    channel, in the scene's units) and anisotropy `g`."""
    return ([surface_colour(a, g) for a in albedo], [4 * math.pi * m / (1 - g) for m in mfp])


def random_walk(bsdf, colour, radius, g, ior):
    """Sets a Principled BSDF node `bsdf` to Cycles' Random Walk with base
    colour `colour`, radius `radius` (per channel, from [`medium`]),
    subsurface scale 1, anisotropy `g` and IOR `ior`."""
    bsdf.subsurface_method = "RANDOM_WALK"
    bsdf.inputs["Base Color"].default_value = (*colour, 1.0)
    bsdf.inputs["Subsurface Weight"].default_value = 1.0
    bsdf.inputs["Subsurface Radius"].default_value = radius
    bsdf.inputs["Subsurface Scale"].default_value = 1.0
    bsdf.inputs["Subsurface Anisotropy"].default_value = g
    bsdf.inputs["IOR"].default_value = ior
