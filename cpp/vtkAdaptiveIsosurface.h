/**
 * @class   vtkAdaptiveIsosurface
 * @brief   multiresolution, crack-free isosurfaces of an image within a world-space tolerance
 *
 * vtkAdaptiveIsosurface extracts isosurfaces (one per contour value) of a 3-D vtkImageData as a
 * vtkPolyData of triangles, straight from a diamond hierarchy of the image: where the surface is
 * nearly flat it is made of a few large triangles, where it is curved or detailed of small ones,
 * and every part of it lies within Tolerance (world units) of the full-resolution surface, in
 * the sense of the isosurface error below. Tolerance 0 gives the full-resolution surface, i.e.
 * marching tetrahedra over the finest longest-edge-bisection mesh of the image. The output is
 * watertight wherever the full-resolution surface is (closed surfaces that do not reach the image
 * boundary stay closed): no cracks between coarse and fine regions.
 *
 * The algorithm (Gregorski et al. 2002, "Recursive Tetrahedral Meshes for Scientific
 * Visualization", §6, §6.1–6.2; Weiss & De Floriani, "Isodiamond Hierarchies", §2.1, §5.1):
 *
 * 1. Diamond hierarchy. The lattice and diamonds of vtkAdaptiveTetrahedra's hierarchy (see that
 *    class): the image is embedded in a (2^L+1)^3 lattice, split into tetrahedra by longest-edge
 *    bisection, and tetrahedra sharing a split edge form diamonds that are always split together,
 *    so any refinement is a conforming tetrahedral mesh. Unlike vtkAdaptiveTetrahedra, this filter
 *    builds the isosurface-only hierarchy: no per-diamond records are precomputed (see Memory
 *    below).
 * 2. Culling of empty diamonds (Gregorski §6.1). A diamond that holds no sample deciding the
 *    surface (no corner of a grid cell an isovalue crosses) cannot hold the surface: it is never
 *    split (only as far as its neighbours' splits force it, for conformity). The refinement work
 *    therefore follows the surface, not the volume.
 * 3. Isosurface error (Gregorski §6.2). A diamond's approximation error e (data units: the largest
 *    difference between the linear interpolation and a sample deciding the surface, measured by
 *    each extraction for its isovalues) moves the surface by about e / |gradient| in space; that
 *    distance, clamped to the size of the diamond's tetrahedra (the surface cannot move further
 *    than the cell that holds it), is the diamond's isosurface error, in world units. Diamonds
 *    containing an isovalue are split, their parents first (closure), while their isosurface error
 *    exceeds Tolerance; with MaximumNumberOfTriangles, the diamond of largest isosurface error goes
 *    first and refinement stops before the budget would be exceeded. Pieces of the surface that a
 *    coarse tetrahedron hides (a speck, a thin branch) and that lie farther than Tolerance from the
 *    surface drawn are refined back in.
 * 4. Marching tetrahedra on the resulting adaptive, conforming mesh: in each tetrahedron that
 *    straddles an isovalue, the surface is the linear interpolant's zero set (one or two
 *    triangles). Surface points live on mesh edges and are shared by edge (deduplicated through
 *    the edge's two lattice endpoints), and the mesh is conforming, so neighbouring tetrahedra
 *    produce the same point on their common edge: the surface has no cracks and no T-junctions.
 *    Triangles are consistently oriented: their normal (right-hand rule) points toward
 *    increasing values.
 *
 * Interaction. The hierarchy is built once per input array (in milliseconds: one pass over the
 * samples to check them) and kept between executions; changing the contour values, Tolerance, MaximumNumberOfTriangles or the
 * region of interest re-runs only the extraction, which reads the samples again where the surface
 * passes (the filter keeps a reference to the input array for that, see Memory below).
 * GetNumberOfHierarchyBuilds() counts the builds. The hierarchy is rebuilt when the input array,
 * its values (MTime), its name or the image geometry (extent, origin, spacing) change. The
 * adaptive mesh (split set) of the last extraction is kept with the hierarchy (and dropped with
 * it): when only ComputeNormals, ComputeScalars or GenerateCarrierTetrahedra change, the next
 * execution reuses it and skips the refinement (GetNumberOfReusedMeshes() counts those); a change
 * of the contour values, Tolerance, the budget or the region refines from the root, which was
 * measured never slower than starting from the previous mesh (Gregorski §6.1; see
 * IsoState::extract in the core, diamonds::isosurface::state).
 *
 * Options:
 * - contour values (SetValue / SetNumberOfContours / GenerateValues, as vtkFlyingEdges3D): one
 *   surface per value, all in the one output; at least one is required.
 * - Tolerance: world units, >= 0 (default 0: full resolution). A good start is two and a half voxel
 *   diagonals (what ParaView's property panel sets) or 0.2 %-1 % of the image diagonal. The field data
 *   "RelativeTolerance" and GetRelativeTolerance() give it as a fraction of the diagonal of the
 *   whole image.
 * - MaximumNumberOfTriangles: 0 = no limit.
 * - UseRegionOfInterest / RegionOfInterest: Tolerance applies only to diamonds touching the box
 *   (world bounds); elsewhere the surface is as coarse as conformity allows.
 * - ComputeNormals (default on): point normals "Normals" (float, unit length): the gradient of
 *   the samples at the point (central differences at the lattice points, one-sided at the image
 *   boundary, interpolated trilinearly over the grid cell holding the point; the gradient of the
 *   carrying tetrahedron where that vanishes); they point toward increasing values, like the triangle
 *   orientation (vtkFlyingEdges3D and vtkContourFilter orient both toward decreasing values).
 * - ComputeScalars (default on, as vtkContourFilter's): a point array named like the processed
 *   array, of its type, whose value at every point is the point's isovalue.
 * - GenerateCarrierTetrahedra (default off): fills output port 1 with the tetrahedra of the adaptive
 *   mesh that carry the surface, as a vtkUnstructuredGrid like vtkAdaptiveTetrahedra's output
 *   (VTK_TETRA, input point data passed through, cell data "BisectionDepth" and "IsosurfaceError" — the
 *   isosurface error of the tetrahedron's diamond in world units —, field data "NumberOfTetrahedra"
 *   and "MaximumError", the largest IsosurfaceError). Port 1 is an empty vtkUnstructuredGrid
 *   otherwise.
 *
 * Output port 0 (vtkPolyData): points in double precision; triangles only; point data "Normals"
 * (when ComputeNormals), the scalar (when ComputeScalars) and every other point array of the input
 * interpolated at the points as vtkContourFilter does (each point lies on an edge between two
 * samples, or is one; types kept, integers rounded); field data "ErrorBound" (double, the
 * largest isosurface error, world units, of the diamonds carrying the surface, over the whole
 * surface: at most Tolerance unless the triangle budget stopped refinement or a region of interest
 * left the rest coarse), "NumberOfTriangles", "Tolerance" and "RelativeTolerance", next to the
 * input's field data.
 *
 * Memory and time. The filter builds the isosurface-only hierarchy: no per-diamond records (the
 * build takes milliseconds; HierarchyMemorySize is 0). Each extraction measures the isosurface
 * errors at the samples that decide its surface (the corners of the grid cells its isovalues cross)
 * and keeps them, 2 bytes and 1 bit per input point, while only Tolerance (not below the one they
 * were measured for), the region, the budget or the outputs change; new isovalues measure them
 * again. The smallest gradient of each diamond's tetrahedra is cached too (2 bytes per point, for
 * every isovalue), plus about one bit per point for the kept adaptive mesh (none after a budget
 * query). To re-read samples near the surface, the filter holds a reference
 * to the processed input array while the hierarchy is cached (no copy, except for 64-bit integer
 * or non-contiguous arrays, which are converted once); ReleaseHierarchy() drops both.
 *
 * Distributed data (MPI: pvbatch, pvserver): when the global vtkMultiProcessController has more
 * than one process, the union of the ranks' outputs is exactly the surface one process extracts
 * from the whole image (same triangles, points, normals and scalars, up to order and point ids),
 * each triangle on exactly one rank (the one whose piece holds the centroid of the tetrahedron
 * carrying it, cells half-open), watertight across pieces. Every rank with a piece gathers every
 * rank's piece of the array (the whole image; memory per rank is that of the whole image, the
 * gather is repeated only when some rank's input changed) and runs the serial
 * extraction, then writes its share. The output carries the point array "GlobalPointIds" (the
 * point's index in the whole surface, the same on every rank; set as the global ids) and field
 * data "TrianglesPerRank", "SecondsPerRank", "BytesSentPerRank", "ExchangeSecondsPerRank" and
 * "PeakMemoryPerRank" (one value per rank each); "NumberOfTriangles" is the total over the ranks.
 * The carrier tetrahedra on port 1 are split between the ranks the same way (point data: the
 * processed array only). An empty piece takes part and outputs nothing.
 *
 * Errors (vtkErrorMacro, empty outputs, no crash): no contour value, or a NaN/Inf one; negative or
 * non-finite Tolerance; negative MaximumNumberOfTriangles; fewer than 2 points along an axis (2-D
 * images); no point scalars (cell data only: apply Cell Data to Point Data first); a
 * multi-component array; NaN or Inf samples; a region of interest outside the image; an oriented
 * image; an image of more than 2^32 points or whose hierarchy would not fit in memory. Arrays of
 * 8-, 16- and 32-bit integers, float and double are read in place; 64-bit integer arrays are
 * converted to double with a warning (refused beyond 2^53).
 *
 * Progress is reported through UpdateProgress (after the hierarchy build, after the extraction,
 * then the output); AbortExecute / CheckAbort, checked between these steps, leaves the outputs
 * empty (a hierarchy already built is kept); under MPI an abort on one rank ends every rank's
 * execution. The flag is cleared by the next execution after a property or the input changed.
 *
 * The core is written in Rust (crate diamonds-core) and reached through one cxx bridge (crate
 * diamonds-bridge); it runs on a thread pool of its own, independent of VTK's SMP backend.
 *
 * @sa
 * vtkFlyingEdges3D, vtkContourFilter (full-resolution isosurfaces), vtkDecimatePro,
 * vtkQuadricDecimation (reducing them afterwards), vtkAdaptiveTetrahedra (adaptive tetrahedral
 * meshes of the same lattice, from the full hierarchy)
 */

#ifndef vtkAdaptiveIsosurface_h
#define vtkAdaptiveIsosurface_h

#include "vtkDiamondsModule.h" // For export macro
#include "vtkPolyDataAlgorithm.h"

class vtkContourValues;
class vtkImageData;
class vtkMultiProcessController;
class vtkUnstructuredGrid;

class VTKDIAMONDS_EXPORT vtkAdaptiveIsosurface : public vtkPolyDataAlgorithm
{
public:
  static vtkAdaptiveIsosurface* New();
  vtkTypeMacro(vtkAdaptiveIsosurface, vtkPolyDataAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  /**
   * Includes the MTime of the contour values.
   */
  vtkMTimeType GetMTime() override;

  ///@{
  /**
   * The contour values (isovalues), as in vtkFlyingEdges3D: SetValue(i, v) sets value i (growing
   * the list as needed), SetNumberOfContours(n) resizes it, GenerateValues(n, min, max) fills it
   * with n equally spaced values. Each value gives one surface. Default: none (at least one is
   * required; ParaView's panel starts with the middle of the array's range).
   */
  void SetValue(int i, double value);
  double GetValue(int i);
  double* GetValues();
  void SetNumberOfContours(int number);
  vtkIdType GetNumberOfContours();
  void GenerateValues(int numContours, double rangeStart, double rangeEnd);
  ///@}

  ///@{
  /**
   * Isosurface error tolerance in world units: every part of the output lies within this distance
   * (in the sense of Gregorski's isosurface error) of the full-resolution surface. 0 (default)
   * gives the full-resolution surface. Must be >= 0.
   */
  vtkSetMacro(Tolerance, double);
  vtkGetMacro(Tolerance, double);
  ///@}

  /**
   * Tolerance divided by the diagonal of the whole input image at the last execution (0 before the
   * first execution or for an empty input).
   */
  vtkGetMacro(RelativeTolerance, double);

  ///@{
  /**
   * Upper bound on the number of output triangles; 0 (default) means no limit. When the budget
   * binds, the diamonds of largest isosurface error are split first and Tolerance may not be met
   * (the field data ErrorBound tells what was reached). Must be >= 0.
   */
  vtkSetMacro(MaximumNumberOfTriangles, vtkIdType);
  vtkGetMacro(MaximumNumberOfTriangles, vtkIdType);
  ///@}

  ///@{
  /**
   * When on, Tolerance applies only to diamonds that touch RegionOfInterest; the surface stays
   * coarse elsewhere. Default off.
   */
  vtkSetMacro(UseRegionOfInterest, vtkTypeBool);
  vtkGetMacro(UseRegionOfInterest, vtkTypeBool);
  vtkBooleanMacro(UseRegionOfInterest, vtkTypeBool);
  ///@}

  ///@{
  /**
   * The region of interest as world bounds (xmin, xmax, ymin, ymax, zmin, zmax). It must touch the
   * image bounds; it may extend beyond them. Default (0, 1, 0, 1, 0, 1).
   */
  vtkSetVector6Macro(RegionOfInterest, double);
  vtkGetVector6Macro(RegionOfInterest, double);
  ///@}

  ///@{
  /**
   * Point normals "Normals" from the sample gradient, unit length, toward increasing values.
   * Default on.
   */
  vtkSetMacro(ComputeNormals, vtkTypeBool);
  vtkGetMacro(ComputeNormals, vtkTypeBool);
  vtkBooleanMacro(ComputeNormals, vtkTypeBool);
  ///@}

  ///@{
  /**
   * A point array named like the processed array (same type) holding each point's isovalue.
   * Default off.
   */
  vtkSetMacro(ComputeScalars, vtkTypeBool);
  vtkGetMacro(ComputeScalars, vtkTypeBool);
  vtkBooleanMacro(ComputeScalars, vtkTypeBool);
  ///@}

  ///@{
  /**
   * When on, output port 1 holds the tetrahedra carrying the surface (see the class comment);
   * otherwise it is empty. Default off.
   */
  vtkSetMacro(GenerateCarrierTetrahedra, vtkTypeBool);
  vtkGetMacro(GenerateCarrierTetrahedra, vtkTypeBool);
  vtkBooleanMacro(GenerateCarrierTetrahedra, vtkTypeBool);
  ///@}

  /**
   * Which hierarchy the surface is extracted from (Weiss & De Floriani, "Isodiamond Hierarchies"):
   * HIERARCHY_FULL (default) the diamond hierarchy of the whole image, any contour values, read
   * from the samples; HIERARCHY_RELEVANT or HIERARCHY_MINIMAL an isodiamond hierarchy (RI: active
   * and relevant isodiamonds, §6; MI: active and creation isodiamonds only, §7) of the one contour
   * value, built when the value (or the input) changes and kept, from which every Tolerance is
   * extracted without reading the samples. It stores the split set of the full hierarchy at each
   * rung of a ladder of tolerances (4 %, 2 %, 1 %, 0.5 %, 0.25 %, 0.125 % and 0.0625 % of the
   * image diagonal, then 0): a Tolerance gives the surface Full gives at the finest rung at or
   * below it (exactly Full's at a rung; finer than Full's between rungs). Normals are those of the
   * surface (the area-weighted mean of its triangles' normals at each point), not the gradient;
   * MaximumNumberOfTriangles picks the finest rung at or above Tolerance whose surface fits. Not
   * available with it (error): more than one contour value, a region of interest, carrier
   * tetrahedra, distributed (MPI) execution.
   */
  enum HierarchyChoice
  {
    HIERARCHY_FULL = 0,
    HIERARCHY_RELEVANT = 1,
    HIERARCHY_MINIMAL = 2
  };
  vtkSetClampMacro(Hierarchy, int, HIERARCHY_FULL, HIERARCHY_MINIMAL);
  vtkGetMacro(Hierarchy, int);

  /**
   * Number of times this filter has built a diamond hierarchy (one per execution whose input array
   * or geometry changed; none when only the contour values, Tolerance, the budget or the region
   * changed).
   */
  vtkGetMacro(NumberOfHierarchyBuilds, vtkIdType);

  /**
   * Number of times this filter has built an isodiamond hierarchy (Hierarchy RELEVANT or MINIMAL:
   * once per contour value, choice or input; none when only Tolerance or the budget changed).
   */
  vtkGetMacro(NumberOfIsodiamondBuilds, vtkIdType);

  /**
   * Number of executions that reused the adaptive mesh of the previous one instead of refining:
   * those where nothing that drives refinement changed (same hierarchy, contour values, Tolerance
   * and region, no triangle budget), i.e. only ComputeNormals, ComputeScalars or
   * GenerateCarrierTetrahedra. Other changes refine from the root (measured no slower than from the
   * previous mesh); the surface is the same either way.
   */
  vtkGetMacro(NumberOfReusedMeshes, vtkIdType);

  /**
   * Bytes of the hierarchy in use (also field data "HierarchyMemorySize"). Full: the processed
   * array's values, which the extraction reads again (a reference to the input array, not a
   * copy), plus what it keeps between executions (the isosurface errors of the last isovalues, the
   * smallest gradients, the brick ranges and the adaptive mesh). Relevant or Minimal: the
   * isodiamond hierarchy (its isodiamonds, crossings and lookups).
   */
  vtkIdType GetHierarchyMemorySize();

  /**
   * Frees the cached hierarchy and the reference to the input array; the next execution rebuilds.
   */
  void ReleaseHierarchy();

protected:
  vtkAdaptiveIsosurface();
  ~vtkAdaptiveIsosurface() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int FillOutputPortInformation(int port, vtkInformation* info) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  // RequestData on more than one rank: every rank's share of the serial surface.
  int RequestDistributed(vtkMultiProcessController* controller, vtkInformationVector** inputVector,
    vtkImageData* input, vtkPolyData* output, vtkUnstructuredGrid* carrier);

  vtkContourValues* ContourValues;
  double Tolerance;
  double RelativeTolerance;
  vtkIdType MaximumNumberOfTriangles;
  vtkTypeBool UseRegionOfInterest;
  double RegionOfInterest[6];
  vtkTypeBool ComputeNormals;
  vtkTypeBool ComputeScalars;
  vtkTypeBool GenerateCarrierTetrahedra;
  int Hierarchy;
  vtkIdType NumberOfHierarchyBuilds;
  vtkIdType NumberOfIsodiamondBuilds;
  vtkIdType NumberOfReusedMeshes;

private:
  vtkAdaptiveIsosurface(const vtkAdaptiveIsosurface&) = delete;
  void operator=(const vtkAdaptiveIsosurface&) = delete;

  class vtkInternals;
  vtkInternals* Internals;
};

#endif
