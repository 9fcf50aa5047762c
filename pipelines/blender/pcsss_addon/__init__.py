"""Point-cloud SSS for Blender: a panel in the 3D view's sidebar (the
"SSS" tab) that bakes subsurface scattering onto the active mesh with
the scene's own lights and camera, as `make bake` bakes it (bake.py),
writes `ssM`, `ssS` and their sum `sss` as colour attributes (an
Attribute node reads them), and sets up the Cycles Random Walk material
of the same medium to render beside it (docs/GUIDE.md#blender).

Installed as an extension (Blender 4.2+): `make blender-addon` writes
target/blender/pcsss-addon.zip, with the pcsss wheel in it; Edit >
Preferences > Get Extensions > Install from Disk.
"""

import bpy

from . import bake


def _presets(_self, _context):
    return [(p, p, f"Jensen et al. 2001's {p}") for p in bake.PRESETS]


class PcsssSettings(bpy.types.PropertyGroup):
    preset: bpy.props.EnumProperty(name="Preset", items=_presets, default=9,
                                   description="A measured medium (formats/MATERIAL.md)")
    material_file: bpy.props.StringProperty(name="Material file", subtype="FILE_PATH",
                                            description="A material file, in place of the preset")
    method: bpy.props.EnumProperty(
        name="Method",
        items=[("diffusion", "Diffusion", "The physical kernel: fast, right on thick flat parts"),
               ("walk", "Random walks", "Walks through the mesh: converge on any shape, cost more")],
        default="diffusion")
    count: bpy.props.IntProperty(name="Points", default=100_000, min=100, max=20_000_000,
                                 description="Points scattered on the mesh")
    walks: bpy.props.IntProperty(name="Walks", default=16, min=1, max=4096,
                                 description="Random walks a point (method: random walks)")
    single: bpy.props.BoolProperty(name="Single scattering", default=True,
                                   description="ssS, seen from the scene's camera")
    seed: bpy.props.IntProperty(name="Seed", default=0, min=0)


class PCSSS_OT_bake(bpy.types.Operator):
    """Bake subsurface scattering onto the active mesh (colour attributes ssM, ssS, sss)"""
    bl_idname = "object.pcsss_bake"
    bl_label = "Bake SSS"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        return context.active_object is not None and context.active_object.type == "MESH"

    def execute(self, context):
        s = context.scene.pcsss
        obj = context.active_object
        try:
            material = bake.material_option(s.preset, s.material_file)
            v = bake.bake_object(context, obj, material, count=s.count, method=s.method, walks=s.walks,
                                 single=s.single, seed=s.seed)
        except (bake.BakeError, RuntimeError, ValueError, OSError) as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        self.report({"INFO"}, f"{obj.name}: {len(v)} vertices baked (colour attribute sss)")
        return {"FINISHED"}


class PCSSS_OT_cycles_material(bpy.types.Operator):
    """Give the active mesh Cycles' Random Walk material of the medium it was baked with"""
    bl_idname = "object.pcsss_cycles_material"
    bl_label = "Cycles Material"
    bl_options = {"REGISTER", "UNDO"}

    @classmethod
    def poll(cls, context):
        o = context.active_object
        return o is not None and o.type == "MESH" and "pcsss_mfp" in o

    def execute(self, context):
        try:
            mat = bake.cycles_material(context.active_object)
        except bake.BakeError as e:
            self.report({"ERROR"}, str(e))
            return {"CANCELLED"}
        self.report({"INFO"}, f"material {mat.name}: Random Walk, the bake's medium")
        return {"FINISHED"}


class PCSSS_PT_panel(bpy.types.Panel):
    bl_label = "Subsurface Scattering"
    bl_idname = "PCSSS_PT_panel"
    bl_space_type = "VIEW_3D"
    bl_region_type = "UI"
    bl_category = "SSS"

    def draw(self, context):
        s = context.scene.pcsss
        col = self.layout.column()
        col.prop(s, "preset")
        col.prop(s, "material_file")
        col.prop(s, "method")
        col.prop(s, "count")
        if s.method == "walk":
            col.prop(s, "walks")
        col.prop(s, "single")
        col.prop(s, "seed")
        col.operator(PCSSS_OT_bake.bl_idname)
        col.operator(PCSSS_OT_cycles_material.bl_idname)


CLASSES = (PcsssSettings, PCSSS_OT_bake, PCSSS_OT_cycles_material, PCSSS_PT_panel)


def register():
    for c in CLASSES:
        bpy.utils.register_class(c)
    bpy.types.Scene.pcsss = bpy.props.PointerProperty(type=PcsssSettings)


def unregister():
    del bpy.types.Scene.pcsss
    for c in reversed(CLASSES):
        bpy.utils.unregister_class(c)
