"""Render a Photometria result (.vtu) in true colour to a PNG. Run with ParaView's pvpython.

Usage:
    pvpython scripts/render.py RESULT.vtu [RESULT2.vtu ...] --output OUT.png [options]
    (with no X display: xvfb-run -a pvpython scripts/render.py ...)

What it does:
    Reads the .vtu written by `photometria solve` and shows every patch as a camera would see
    it: the colour of a surface point is its radiance, not a colour map. A diffuse (Lambertian)
    surface of radiosity B (W/m², per RGB channel) has radiance L = B / pi (W/(m² sr)), the same
    in every direction. L is multiplied by an exposure, encoded with the sRGB transfer curve
    (IEC 61966-2-1:1999), clamped to [0, 1] and drawn unlit, as 8-bit RGB straight to the pixels
    (no colour map, no headlight shading: walls of equal radiosity look equal whatever their
    orientation). Faces are drawn from their front side only (back-face culling), so a closed
    room seen from outside shows its inside through the near wall, and faces lying on others
    with their back up (the box bottoms of the Cornell box) cannot z-fight.
    With several inputs the pictures are put side by side in one PNG (same camera, same
    exposure, each --size), each with its --label if given.

Defaults:
    --output        RESULT.png beside the first input
    --size          800x600 (of each panel)
    colours         point data `radiosity` (smooth, per vertex); --cell-data: cell data
                    `radiosity` (flat, one colour per patch)
    --exposure      automatic: the 99th percentile (weighted by patch area) of the brightest
                    channel of L over the non-emitting patches of all inputs maps to 0.9 before
                    the sRGB curve (emitters come out white or saturated, as on a photograph);
                    the value used is printed. Units m² sr / W: display value = sRGB(exposure * L)
    camera          meshes are y up: looking along -z from the +z side (the open face of the
                    Cornell box), view up +y, view angle 39.3 degrees (the Cornell box camera),
                    focal point the centre of the bounding box, far enough back that the
                    bounding box's x-y extent fills the picture with a 5% margin. For the
                    shipped Cornell box this is the classic front view
    --camera-position x,y,z / --focal-point x,y,z / --view-up x,y,z / --view-angle deg
                    override any part of that (a value starting with '-' needs the '=' form:
                    --camera-position=-0.2,0.8,1.9)
    --background    0,0,0 (r,g,b in [0, 1])

Errors (missing file, not a .vtu, no 3-component `radiosity` array, bad option) are one line on
stderr and exit code 1.
"""

import argparse
import math
import os
import sys


def fail(message):
    sys.stderr.write("render.py: error: %s\n" % message)
    sys.exit(1)


def parse_vector(text, name, count=3):
    try:
        values = [float(v) for v in text.split(",")]
    except ValueError:
        values = []
    if len(values) != count or not all(math.isfinite(v) for v in values):
        fail("%s wants %d comma-separated numbers, got '%s'" % (name, count, text))
    return values


def parse_size(text):
    parts = text.lower().split("x")
    try:
        w, h = int(parts[0]), int(parts[1])
        if len(parts) != 2 or w < 16 or h < 16 or w > 16384 or h > 16384:
            raise ValueError
    except (ValueError, IndexError):
        fail("--size wants WxH in pixels (16..16384 each), got '%s'" % text)
    return w, h


def parse_args(argv):
    parser = argparse.ArgumentParser(
        prog="render.py",
        description="Render a photometria solve result (.vtu) in true colour to a PNG.")
    parser.add_argument("inputs", nargs="+", metavar="RESULT.vtu",
                        help="result of photometria solve; several: side by side")
    parser.add_argument("-o", "--output", help="PNG to write (default: first input with .png)")
    parser.add_argument("--size", default="800x600", help="WxH of each panel (default 800x600)")
    data = parser.add_mutually_exclusive_group()
    data.add_argument("--point-data", dest="cells", action="store_false",
                      help="smooth per-vertex radiosity (default)")
    data.add_argument("--cell-data", dest="cells", action="store_true",
                      help="flat per-patch radiosity")
    parser.set_defaults(cells=False)
    parser.add_argument("--exposure", type=float,
                        help="display value = sRGB(exposure * B / pi) (default: automatic)")
    parser.add_argument("--camera-position", metavar="X,Y,Z")
    parser.add_argument("--focal-point", metavar="X,Y,Z")
    parser.add_argument("--view-up", metavar="X,Y,Z")
    parser.add_argument("--view-angle", type=float, metavar="DEG",
                        help="vertical view angle in degrees (default 39.3)")
    parser.add_argument("--label", action="append", default=[],
                        help="caption of a panel (repeat once per input, in order)")
    parser.add_argument("--background", default="0,0,0", metavar="R,G,B")
    parser.add_argument("--back-faces", action="store_true",
                        help="also draw faces seen from behind (default: front faces only)")

    def error(message):
        fail(message)
    parser.error = error
    args = parser.parse_args(argv)
    if args.exposure is not None and not (math.isfinite(args.exposure) and args.exposure > 0):
        fail("--exposure must be a positive number")
    if args.view_angle is not None and not (0 < args.view_angle < 180):
        fail("--view-angle must be in (0, 180) degrees")
    if len(args.label) > len(args.inputs):
        fail("%d --label for %d inputs" % (len(args.label), len(args.inputs)))
    return args


def srgb_encode(linear):
    """IEC 61966-2-1:1999 transfer curve, linear in [0, 1] -> non-linear sRGB value in [0, 1]."""
    import numpy as np
    c = np.clip(linear, 0.0, 1.0)
    return np.where(c <= 0.0031308, 12.92 * c, 1.055 * np.power(c, 1.0 / 2.4) - 0.055)


def load(path, use_cells):
    """Read a .vtu; return (surface polydata, radiance L = B/pi as N x 3 of the points (cells with
    use_cells), (brightest channel of L per non-emitting patch, patch areas or None))."""
    import numpy as np
    import vtk
    from vtk.util.numpy_support import vtk_to_numpy

    if not os.path.exists(path):
        fail("%s: no such file" % path)
    if not os.path.isfile(path) or not os.access(path, os.R_OK):
        fail("%s: not a readable file" % path)
    reader = vtk.vtkXMLUnstructuredGridReader()
    if not reader.CanReadFile(path):
        fail("%s: not a VTK unstructured grid (.vtu) file" % path)
    reader.SetFileName(path)
    reader.GetExecutive().SetReleaseDataFlag(0, 0)
    # Keep VTK's multi-line reader messages off the terminal (the check below says it in one
    # line), then put things back: pvpython sends Python's stderr through the output window too.
    previous = vtk.vtkOutputWindow.GetInstance()
    errors = vtk.vtkFileOutputWindow()
    errors.SetFileName(os.devnull)
    vtk.vtkOutputWindow.SetInstance(errors)
    verbosity = vtk.vtkLogger.GetCurrentVerbosityCutoff()
    vtk.vtkLogger.SetStderrVerbosity(vtk.vtkLogger.VERBOSITY_OFF)
    reader.Update()
    vtk.vtkLogger.SetStderrVerbosity(verbosity)
    vtk.vtkOutputWindow.SetInstance(previous)
    grid = reader.GetOutput()
    if reader.GetErrorCode() != 0 or grid is None or grid.GetNumberOfCells() == 0:
        fail("%s: could not read it as a .vtu with cells" % path)

    where = "cell" if use_cells else "point"
    attributes = grid.GetCellData() if use_cells else grid.GetPointData()
    array = attributes.GetArray("radiosity")
    if array is None or array.GetNumberOfComponents() != 3:
        fail("%s: no 3-component %s data array 'radiosity' (is it from photometria solve?)"
             % (path, where))
    radiance = vtk_to_numpy(array).astype(float).reshape(-1, 3) / math.pi

    # Emitters (cells with emission > 0, and the points of those cells) are left out of the
    # automatic exposure: they are meant to be the brightest thing in the picture.
    emitting = np.zeros(len(radiance), dtype=bool)
    emission = grid.GetCellData().GetArray("emission")
    cell_emits = None
    if emission is not None:
        cell_emits = vtk_to_numpy(emission).reshape(grid.GetNumberOfCells(), -1).max(axis=1) > 0
        if use_cells:
            emitting = cell_emits
        else:
            ids = vtk.vtkIdList()
            for c in np.nonzero(cell_emits)[0]:
                grid.GetCellPoints(int(c), ids)
                for k in range(ids.GetNumberOfIds()):
                    emitting[ids.GetId(k)] = True

    # The automatic exposure is taken over the patches, weighted by their area, so that it
    # neither depends on how finely a surface is meshed nor on point versus cell data.
    cell_radiance = vtk_to_numpy(grid.GetCellData().GetArray("radiosity")).reshape(-1, 3) / math.pi \
        if grid.GetCellData().GetArray("radiosity") is not None else None
    area = grid.GetCellData().GetArray("area")
    if cell_radiance is None or len(cell_radiance) != grid.GetNumberOfCells():
        sample = (radiance[~emitting].max(axis=1), None)  # points (or cells), unweighted
    else:
        keep = ~cell_emits if emission is not None else np.ones(len(cell_radiance), dtype=bool)
        weights = vtk_to_numpy(area).astype(float) if area is not None else None
        sample = (cell_radiance[keep].max(axis=1), weights[keep] if weights is not None else None)

    surface = vtk.vtkGeometryFilter()  # 2D cells kept as they are, winding included
    surface.SetInputData(grid)
    surface.Update()
    polys = surface.GetOutput()
    if polys.GetNumberOfCells() != grid.GetNumberOfCells():
        fail("%s: %d of %d cells are not surface cells" %
             (path, grid.GetNumberOfCells() - polys.GetNumberOfCells(), grid.GetNumberOfCells()))
    return polys, radiance, sample


def auto_exposure(scenes):
    """0.9 / the area-weighted 99th percentile of the brightest channel of L over the
    non-emitting patches of all scenes (1 when that is 0)."""
    import numpy as np
    values = np.concatenate([sample[0] for _, _, sample in scenes])
    if all(sample[1] is not None for _, _, sample in scenes):
        weights = np.concatenate([sample[1] for _, _, sample in scenes])
    else:
        weights = np.ones(len(values))
    if values.size == 0 or weights.sum() <= 0:
        return 1.0
    order = np.argsort(values)
    cumulative = np.cumsum(weights[order]) / weights.sum()
    p99 = float(values[order][min(np.searchsorted(cumulative, 0.99), len(values) - 1)])
    return 0.9 / p99 if p99 > 0 else 1.0


def default_camera(bounds, aspect, view_angle):
    xmin, xmax, ymin, ymax, zmin, zmax = bounds
    centre = [(xmin + xmax) / 2, (ymin + ymax) / 2, (zmin + zmax) / 2]
    half_height = max(ymax - ymin, (xmax - xmin) / aspect) / 2
    distance = 1.05 * half_height / math.tan(math.radians(view_angle) / 2)
    return [centre[0], centre[1], zmax + distance], centre, [0.0, 1.0, 0.0]


def main(argv):
    args = parse_args(argv)
    width, height = parse_size(args.size)
    background = parse_vector(args.background, "--background")

    import numpy as np
    import vtk
    from vtk.util.numpy_support import numpy_to_vtk

    scenes = [load(path, args.cells) for path in args.inputs]
    exposure = args.exposure if args.exposure is not None else auto_exposure(scenes)
    output = args.output or os.path.splitext(args.inputs[0])[0] + ".png"
    folder = os.path.dirname(os.path.abspath(output))
    if not os.path.isdir(folder) or not os.access(folder, os.W_OK):
        fail("%s: cannot write into %s" % (output, folder))

    bounds = list(scenes[0][0].GetBounds())
    for polys, _, _ in scenes[1:]:
        b = polys.GetBounds()
        for k in range(3):
            bounds[2 * k] = min(bounds[2 * k], b[2 * k])
            bounds[2 * k + 1] = max(bounds[2 * k + 1], b[2 * k + 1])
    view_angle = args.view_angle if args.view_angle is not None else 39.3
    position, focal, up = default_camera(bounds, width / height, view_angle)
    if args.camera_position:
        position = parse_vector(args.camera_position, "--camera-position")
    if args.focal_point:
        focal = parse_vector(args.focal_point, "--focal-point")
    if args.view_up:
        up = parse_vector(args.view_up, "--view-up")
    if np.linalg.norm(np.subtract(position, focal)) == 0:
        fail("camera position and focal point coincide")
    if np.linalg.norm(np.cross(np.subtract(focal, position), up)) == 0:
        fail("--view-up is parallel to the viewing direction")

    window = vtk.vtkRenderWindow()
    window.SetOffScreenRendering(1)
    if window.GetClassName() == "vtkXOpenGLRenderWindow" and not os.environ.get("DISPLAY"):
        fail("no X display for this pvpython (an X build): run it as xvfb-run -a pvpython ...")
    window.SetSize(width * len(scenes), height)
    window.SetMultiSamples(8)

    for index, (polys, radiance, _) in enumerate(scenes):
        rgb = np.rint(255.0 * srgb_encode(exposure * radiance)).astype(np.uint8)
        colours = numpy_to_vtk(np.ascontiguousarray(rgb), deep=1)
        colours.SetName("display_rgb")
        if args.cells:
            polys.GetCellData().AddArray(colours)
        else:
            polys.GetPointData().AddArray(colours)

        mapper = vtk.vtkPolyDataMapper()
        mapper.SetInputData(polys)
        mapper.SetScalarModeToUseCellFieldData() if args.cells \
            else mapper.SetScalarModeToUsePointFieldData()
        mapper.SelectColorArray("display_rgb")
        mapper.SetColorModeToDirectScalars()  # the colours as they are: no lookup table
        mapper.ScalarVisibilityOn()
        mapper.SetResolveCoincidentTopologyToPolygonOffset()

        actor = vtk.vtkActor()
        actor.SetMapper(mapper)
        prop = actor.GetProperty()
        prop.LightingOff()  # unlit: the colour is the radiance
        prop.SetAmbient(1.0)
        prop.SetDiffuse(0.0)
        prop.SetSpecular(0.0)
        prop.SetBackfaceCulling(0 if args.back_faces else 1)

        renderer = vtk.vtkRenderer()
        renderer.SetViewport(index / len(scenes), 0.0, (index + 1) / len(scenes), 1.0)
        renderer.SetBackground(*background)
        renderer.AddActor(actor)
        camera = renderer.GetActiveCamera()
        camera.SetPosition(*position)
        camera.SetFocalPoint(*focal)
        camera.SetViewUp(*up)
        camera.SetViewAngle(view_angle)
        camera.OrthogonalizeViewUp()
        renderer.ResetCameraClippingRange()

        if index < len(args.label):
            text = vtk.vtkTextActor()
            text.SetInput(args.label[index])
            style = text.GetTextProperty()
            style.SetFontSize(max(12, height // 20))
            style.SetColor(1.0, 1.0, 1.0)
            style.ShadowOn()
            style.SetJustificationToCentered()
            style.SetVerticalJustificationToBottom()
            text.GetPositionCoordinate().SetCoordinateSystemToNormalizedViewport()
            text.GetPositionCoordinate().SetValue(0.5, 0.025)
            renderer.AddViewProp(text)
        window.AddRenderer(renderer)

    window.Render()
    grab = vtk.vtkWindowToImageFilter()
    grab.SetInput(window)
    grab.SetInputBufferTypeToRGB()
    grab.ReadFrontBufferOff()
    grab.Update()
    writer = vtk.vtkPNGWriter()
    writer.SetCompressionLevel(9)
    writer.SetFileName(output)
    writer.SetInputConnection(grab.GetOutputPort())
    writer.Write()
    if writer.GetErrorCode() != 0 or not os.path.isfile(output):
        fail("%s: could not write the PNG" % output)
    print("render.py: wrote %s (%dx%d, %s data, exposure %.4g m2 sr/W)"
          % (output, width * len(scenes), height, "cell" if args.cells else "point", exposure))
    sys.stdout.flush()  # pvpython may leave without flushing once a render window existed


if __name__ == "__main__":
    main(sys.argv[1:])
