#!/usr/bin/python3
# Renders one frame of a bondem VTK output to a PNG: the particles as spheres of their true size
# coloured by a point array, the tools, walls and domain box drawn lightly, the camera framing the
# particles. Debian's VTK (python3-vtk9); see docs/paraview.md, "Pictures without ParaView".
#
# The shebang names Debian's interpreter: python3-vtk9 installs into /usr/lib/python3/dist-packages,
# which only /usr/bin/python3 searches (a pyenv or /usr/local python3 earlier on PATH does not).
import argparse
import math
import os
import shutil
import sys
import xml.etree.ElementTree as ET

UNITS = {"velocity": "m/s", "displacement": "m", "force": "N", "torque": "N m", "diameter": "m",
         "radius": "m", "angular_velocity": "rad/s", "temperature": "K",
         "peak_temperature": "K", "heat_rate": "W"}
# Anchor colours (RGB 0-255) of perceptually ordered maps, interpolated in Lab space.
COLORMAPS = {
    "viridis": [(68, 1, 84), (59, 82, 139), (33, 145, 140), (94, 201, 98), (253, 231, 37)],
    "plasma": [(13, 8, 135), (126, 3, 168), (204, 71, 120), (248, 149, 64), (240, 249, 33)],
    "coolwarm": [(59, 76, 192), (221, 221, 221), (180, 4, 38)]}
FONT = "/usr/share/fonts/truetype/dejavu/DejaVuSans.ttf"  # Debian's VTK font draws [ as (
VIEWS = {"iso": ((0, 1, 0), (0, 0, 1)), "side": ((0, 1, 0), (0, 0, 1)),  # look along, view up
         "front": ((-1, 0, 0), (0, 0, 1)), "top": ((0, 0, -1), (0, 1, 0))}


def parse_args():
    p = argparse.ArgumentParser(
        description="Render a frame of a bondem run (output.vtk_interval) to a PNG, off screen.",
        epilog="Example: scripts/render-png.py output/powder_spreading_ci --view side "
               "-o spreading.png. Without a DISPLAY it re-runs itself under xvfb-run.")
    p.add_argument("input", help="output directory (particles.pvd) or a particles_<n>.vtp file")
    when = p.add_mutually_exclusive_group()
    when.add_argument("--frame", type=int, default=-1,
                      help="frame index in particles.pvd, negative from the end (default: last)")
    when.add_argument("--time", type=float, help="the frame nearest this time [s]")
    p.add_argument("--color-by", default="velocity", metavar="ARRAY[:x|y|z]",
                   help="point array; a vector by its magnitude unless a component is given "
                        "(default: velocity)")
    p.add_argument("--range", type=float, nargs=2, metavar=("MIN", "MAX"),
                   help="fixed colour range (default: the frame's; from 0 for a magnitude)")
    p.add_argument("--colormap", choices=sorted(COLORMAPS),
                   help="default: plasma for temperatures, viridis otherwise")
    p.add_argument("--view", choices=list(VIEWS), default="iso",
                   help="iso (default: side turned 30 deg about z and 30 deg up), "
                        "side (along +y at the x-z plane), front (along -x), top (down -z)")
    p.add_argument("--azimuth", type=float, default=0, help="turn the view about z [deg]")
    p.add_argument("--elevation", type=float, default=0, help="tilt the view up [deg]")
    p.add_argument("--zoom", type=float, default=1.0, help="> 1 zooms in on the particles' centre")
    p.add_argument("--size", type=int, nargs=2, default=(1600, 900), metavar=("W", "H"))
    p.add_argument("--no-boundaries", action="store_true", help="particles only")
    p.add_argument("-o", "--output", help="PNG file (default: the frame's .vtp name, .png)")
    return p.parse_args()


def relaunch_if_needed():
    """Re-run under Debian's python3 if VTK is missing, under xvfb-run if there is no X display."""
    argv = [os.path.abspath(__file__)] + sys.argv[1:]
    try:
        import vtkmodules  # noqa: F401
    except ImportError:
        if os.path.exists("/usr/bin/python3") and sys.executable != "/usr/bin/python3":
            os.execv("/usr/bin/python3", ["/usr/bin/python3"] + argv)
        sys.exit("render-png: no VTK for Python; install Debian's python3-vtk9")
    # Debian builds VTK 9.1 for X11 alone (no EGL or OSMesa window), so even off-screen rendering
    # needs an X server: Xvfb, with Mesa's llvmpipe drawing in software. The picture is drawn in
    # a framebuffer object, so the virtual screen's size does not limit it.
    if not os.environ.get("DISPLAY") and not os.environ.get("RENDER_PNG_XVFB"):
        xvfb = shutil.which("xvfb-run")
        if not xvfb:
            sys.exit("render-png: no DISPLAY and no xvfb-run; install Debian's xvfb and xauth")
        os.environ["RENDER_PNG_XVFB"] = "1"
        os.execv(xvfb, [xvfb, "-a", "-s", "-screen 0 640x480x24", sys.executable] + argv)


def read_pvd(path):
    """[(time, file)] of a .pvd collection; [] if there is none."""
    if not os.path.isfile(path):
        return []
    return [(float(d.get("timestep")), d.get("file"))
            for d in ET.parse(path).getroot().iter("DataSet")]


def pick_frame(args):
    """The particles file and [(kind, file)] of the tools, walls and domain of the same frame."""
    if os.path.isdir(args.input):
        folder, frames = args.input, read_pvd(os.path.join(args.input, "particles.pvd"))
        if not frames:
            sys.exit(f"render-png: no frames in {args.input}/particles.pvd "
                     "(a run with output.vtk_interval writes them)")
        if args.time is not None:
            index = min(range(len(frames)), key=lambda k: abs(frames[k][0] - args.time))
        elif -len(frames) <= args.frame < len(frames):
            index = args.frame % len(frames)
        else:
            sys.exit(f"render-png: no frame {args.frame}: {len(frames)} frames")
        particles = os.path.join(folder, frames[index][1])
    elif os.path.isfile(args.input):
        folder, particles = os.path.dirname(args.input) or ".", args.input
        names = [f for _, f in read_pvd(os.path.join(folder, "particles.pvd"))]
        base = os.path.basename(particles)
        index = names.index(base) if base in names else None
    else:
        sys.exit(f"render-png: {args.input} not found")
    # walls.pvd and tools.pvd list one file per frame, in the order of particles.pvd.
    boundaries = [(kind, os.path.join(folder, listed[index][1])) for kind in ("tools", "walls")
                  for listed in [read_pvd(os.path.join(folder, kind + ".pvd"))]
                  if index is not None and index < len(listed)]
    boundaries.append(("domain", os.path.join(folder, "domain.vtp")))
    return particles, [(kind, f) for kind, f in boundaries if os.path.isfile(f)]


def read_vtp(path):
    from vtkmodules.vtkIOXML import vtkXMLPolyDataReader
    reader = vtkXMLPolyDataReader()
    reader.SetFileName(path)
    reader.Update()
    return reader.GetOutput()


def inside_box(surface, bounds):
    """The part of a closed surface inside bounds, capped where cut. A blade or roller reaches
    past the periodic sides, where it would stand between the camera and the bed."""
    from vtkmodules.vtkCommonDataModel import vtkPlane, vtkPlaneCollection
    from vtkmodules.vtkFiltersCore import vtkCleanPolyData, vtkPolyDataNormals
    from vtkmodules.vtkFiltersGeneral import vtkClipClosedSurface
    planes = vtkPlaneCollection()
    for k, bound in enumerate(bounds):
        plane = vtkPlane()
        plane.SetOrigin(*[bound if a == k // 2 else 0 for a in range(3)])
        plane.SetNormal(*[(-1 if k % 2 else 1) * (a == k // 2) for a in range(3)])
        planes.AddItem(plane)
    # Merged corners and consistent normals make the faces one closed, oriented surface to cap.
    merge, orient, clip = vtkCleanPolyData(), vtkPolyDataNormals(), vtkClipClosedSurface()
    merge.SetInputData(surface)
    orient.SetInputConnection(merge.GetOutputPort())
    orient.AutoOrientNormalsOn()
    orient.SplittingOff()
    clip.SetInputConnection(orient.GetOutputPort())
    clip.SetClippingPlanes(planes)
    clip.Update()
    return clip.GetOutput()


def nice_ticks(lo, hi):
    """Round values in [lo, hi], 4 to 9 of them, and the printf format to label them."""
    power = math.floor(math.log10((hi - lo) / 8))
    mantissa = next(m for m in (1, 2, 5, 10) if (hi - lo) / (m * 10 ** power) <= 8.0001)
    step = mantissa * 10 ** power
    ticks = [k * step for k in range(math.ceil(lo / step - 1e-9), math.floor(hi / step + 1e-9) + 1)]
    decimals = max(0, -power - (mantissa == 10))
    plain = step >= 1e-3 and max(abs(lo), abs(hi)) < 1e5
    return ticks, f"%.{decimals}f" if plain else "%.3g"


def main():
    args = parse_args()
    relaunch_if_needed()
    import vtkmodules.vtkRenderingFreeType  # noqa: F401  (text of the colour bar)
    import vtkmodules.vtkRenderingOpenGL2  # noqa: F401  (the OpenGL render window)
    from vtkmodules.vtkCommonCore import vtkDoubleArray
    from vtkmodules.vtkFiltersSources import vtkSphereSource
    from vtkmodules.vtkIOImage import vtkPNGWriter
    from vtkmodules.vtkRenderingAnnotation import vtkScalarBarActor
    from vtkmodules.vtkRenderingCore import (vtkActor, vtkColorTransferFunction, vtkGlyph3DMapper,
                                             vtkPolyDataMapper, vtkRenderer, vtkRenderWindow,
                                             vtkWindowToImageFilter)

    particles_file, boundaries = pick_frame(args)
    data = read_vtp(particles_file)
    points, count = data.GetPointData(), data.GetNumberOfPoints()
    available = [points.GetArrayName(k) for k in range(points.GetNumberOfArrays())]
    name, _, part = args.color_by.partition(":")
    for needed in (name, "diameter"):
        if needed not in available:
            sys.exit(f"render-png: {particles_file} has no point array '{needed}'; "
                     f"it has: {', '.join(available) or 'none'}")
    array = points.GetArray(name)
    if part and (part not in ("x", "y", "z") or array.GetNumberOfComponents() != 3):
        sys.exit(f"render-png: --color-by {args.color_by}: x, y or z of a 3-vector only")
    component = "xyz".index(part) if part else (-1 if array.GetNumberOfComponents() > 1 else 0)
    lo, hi = args.range or (array.GetRange(component) if count else (0, 1))
    if component < 0 and not args.range:
        lo = 0.0  # a magnitude: its scale starts at zero
    if not hi > lo:
        lo, hi = lo - 0.5 * max(abs(lo), 1e-12), hi + 0.5 * max(abs(hi), 1e-12)

    # Spheres of diameter 1 scaled by 'diameter': every particle at its true size. The glyph
    # mapper instances one sphere rather than copying it per particle; a coarser sphere past
    # 20 000 particles keeps 10^5 quick in software rendering.
    sphere = vtkSphereSource()
    sphere.SetRadius(0.5)
    sphere.SetThetaResolution(24 if count < 20000 else 12)
    sphere.SetPhiResolution(16 if count < 20000 else 8)
    glyphs = vtkGlyph3DMapper()
    glyphs.SetInputData(data)
    glyphs.SetSourceConnection(sphere.GetOutputPort())
    glyphs.SetScaleArray("diameter")
    glyphs.SetScaleModeToScaleByMagnitude()
    colors = vtkColorTransferFunction()
    colors.SetColorSpaceToLab()
    anchors = COLORMAPS[args.colormap or ("plasma" if "temperature" in name else "viridis")]
    for k, rgb in enumerate(anchors):
        colors.AddRGBPoint(lo + (hi - lo) * k / (len(anchors) - 1), *(c / 255 for c in rgb))
    colors.SetVectorMode(colors.MAGNITUDE if component < 0 else colors.COMPONENT)
    colors.SetVectorComponent(max(component, 0))
    glyphs.SetLookupTable(colors)
    glyphs.SetScalarModeToUsePointFieldData()
    glyphs.SelectColorArray(name)
    glyphs.SetScalarRange(lo, hi)
    spheres = vtkActor()
    spheres.SetMapper(glyphs)
    spheres.GetProperty().SetSpecular(0.2)
    spheres.GetProperty().SetSpecularPower(20)

    # The scene on the left, the colour bar in a strip of its own so that it never covers the bed.
    font = max(12, round(args.size[1] / 40))  # text size in pixels, in proportion to the picture
    bar_width = min(0.5, 11 * font / args.size[0])
    scene, legend = vtkRenderer(), vtkRenderer()
    scene.SetViewport(0, 0, 1 - bar_width, 1)
    legend.SetViewport(1 - bar_width, 0, 1, 1)
    for renderer in (scene, legend):
        renderer.SetBackground(1, 1, 1)
    scene.AddActor(spheres)

    # Boundaries light and see-through: tools grey-blue, walls a faint grey, the domain as lines.
    styles = {"tools": ((0.45, 0.5, 0.6), 0.3), "walls": ((0.7, 0.7, 0.7), 0.15),
              "domain": ((0.55, 0.55, 0.55), 1.0)}
    domain = dict(boundaries).get("domain")
    for kind, path in [] if args.no_boundaries else boundaries:
        surface = read_vtp(path)
        if kind == "tools" and domain:
            surface = inside_box(surface, read_vtp(domain).GetBounds())
        mapper = vtkPolyDataMapper()
        mapper.SetInputData(surface)
        mapper.ScalarVisibilityOff()
        actor = vtkActor()
        actor.SetMapper(mapper)
        prop = actor.GetProperty()
        prop.SetColor(*styles[kind][0])
        prop.SetOpacity(styles[kind][1])
        prop.SetEdgeVisibility(kind == "walls")  # a wall's outline; tools' caps are triangles
        prop.SetEdgeColor(0.5, 0.5, 0.5)
        prop.SetAmbient(0.3)
        scene.AddActor(actor)

    label = f"{name} {part}" if part else (f"{name} magnitude" if component < 0 else name)
    title = label + (f"\n[{UNITS[name]}]" if name in UNITS else "")
    time = data.GetFieldData().GetArray("TimeValue")
    if time:
        t = time.GetTuple1(0)
        title += f"\nt = {t * 1e3:.4g} ms" if t < 1 else f"\nt = {t:.4g} s"
    bar = vtkScalarBarActor()
    bar.SetLookupTable(colors)
    bar.SetTitle(title)
    ticks, number_format = nice_ticks(lo, hi)
    bar.SetUseCustomLabels(True)
    bar.SetCustomLabels(vtkDoubleArray())
    for tick in ticks:
        bar.GetCustomLabels().InsertNextValue(tick)
    bar.SetLabelFormat(number_format)
    bar.UnconstrainedFontSizeOn()
    bar.SetPosition(0.05, 0.05)
    bar.SetPosition2(0.9, 0.85)
    bar.SetBarRatio(0.3)
    bar.SetVerticalTitleSeparation(font // 2)
    for text in (bar.GetTitleTextProperty(), bar.GetLabelTextProperty()):
        text.SetColor(0, 0, 0)
        text.SetFontSize(font)
        text.BoldOff()
        text.ItalicOff()
        text.ShadowOff()
        if os.path.isfile(FONT):
            text.SetFontFamilyAsString("File")
            text.SetFontFile(FONT)
    legend.AddActor2D(bar)

    window = vtkRenderWindow()
    window.SetOffScreenRendering(1)
    window.SetSize(*args.size)
    # Anti-aliasing: cheap for thousands of particles; in software it costs 1 GB at 10^5.
    window.SetMultiSamples(8 if count < 20000 else 0)
    window.AddRenderer(scene)
    window.AddRenderer(legend)
    frame_view(scene, data, args, (1 - bar_width) * args.size[0] / args.size[1])
    window.Render()
    grab = vtkWindowToImageFilter()
    grab.SetInput(window)
    grab.ReadFrontBufferOff()
    grab.ShouldRerenderOff()  # rendered once above
    writer = vtkPNGWriter()
    output = args.output or os.path.splitext(particles_file)[0] + ".png"
    writer.SetFileName(output)
    writer.SetInputConnection(grab.GetOutputPort())
    writer.Write()
    print(f"render-png: {output}: {count} particles, {label} {lo:.4g} to {hi:.4g}")


def frame_view(scene, data, args, aspect):
    """Parallel projection along the view, scaled so that the particles' box fills the picture."""
    bounds = list(data.GetBounds())
    if data.GetNumberOfPoints():
        r = data.GetPointData().GetArray("diameter").GetRange()[1] / 2
        bounds = [b + (r if k % 2 else -r) for k, b in enumerate(bounds)]
    else:
        bounds = list(scene.ComputeVisiblePropBounds())
    centre = [(bounds[2 * a] + bounds[2 * a + 1]) / 2 for a in range(3)]
    look, up = VIEWS[args.view]
    camera = scene.GetActiveCamera()
    camera.ParallelProjectionOn()
    camera.SetFocalPoint(*centre)
    camera.SetPosition(*(c - d for c, d in zip(centre, look)))
    camera.SetViewUp(*up)
    iso = args.view == "iso"
    camera.Azimuth(args.azimuth - 30 * iso)
    camera.Elevation(args.elevation + 30 * iso)
    camera.OrthogonalizeViewUp()
    scene.ResetCamera(bounds)
    # Back far enough that no wall or tool lies behind the camera (parallel: distance is free).
    everything = scene.ComputeVisiblePropBounds()
    look = camera.GetDirectionOfProjection()
    far = math.dist(everything[0::2], everything[1::2]) + camera.GetDistance()
    camera.SetPosition(*(c - far * d for c, d in zip(centre, look)))
    # ResetCamera fits a sphere round the box; fit the box's corners, for a tight frame.
    up = camera.GetViewUp()
    right = [look[1] * up[2] - look[2] * up[1], look[2] * up[0] - look[0] * up[2],
             look[0] * up[1] - look[1] * up[0]]
    corners = [(x, y, z) for x in bounds[0:2] for y in bounds[2:4] for z in bounds[4:6]]

    def half(axis):
        return max(abs(sum((p - c) * a for p, c, a in zip(q, centre, axis))) for q in corners)

    camera.SetParallelScale(1.04 * max(half(up), half(right) / aspect) / args.zoom)
    scene.ResetCameraClippingRange()


if __name__ == "__main__":
    main()
