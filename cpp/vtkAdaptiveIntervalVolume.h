/**
 * @class   vtkAdaptiveIntervalVolume
 * @brief   multiresolution, conforming tetrahedral interval volumes of an image within a world-space tolerance
 *
 * vtkAdaptiveIntervalVolume extracts the interval volume {ThresholdRange[0] <= f <= ThresholdRange[1]}
 * of a 3-D vtkImageData (the material between two values: bone between two densities, a
 * temperature band) as a vtkUnstructuredGrid of tetrahedra, straight from a diamond hierarchy of
 * the image: large tetrahedra inside the volume and where its bounding surfaces are flat, small ones
 * where they are curved or detailed. Its two bounding surfaces are exactly the surfaces
 * vtkAdaptiveIsosurface draws for the isovalues ThresholdRange[0] and ThresholdRange[1] at the same
 * Tolerance (world units), triangulated; Tolerance 0 gives the exact interval volume of the
 * piecewise-linear field on the finest tetrahedra. The mesh is conforming at every resolution: every
 * interior face is shared by exactly two tetrahedra; faces used once lie on the image boundary or on
 * a bounding surface.
 *
 * The algorithm (Weiss & De Floriani, "Isodiamond Hierarchies", §2.1, §5; Gregorski et al. 2002,
 * §6.1-6.2; the interval-volume tetrahedralisation of Nielson and Sung, cited there):
 *
 * 1. Refinement: the hierarchy is refined exactly as vtkAdaptiveIsosurface refines it for the two
 *    isovalues (empty-diamond culling, isosurface error, the checked two-sided bound), so the inside
 *    of the interval volume stays as coarse as the base mesh allows. Diamonds straddling the far
 *    faces of the lattice whose samples meet the range are split too (they hold the volume).
 * 2. Clipping: each leaf tetrahedron of the adaptive mesh that meets the range is clipped to it (the
 *    field is linear on it), giving a convex polytope whose vertices are samples in the range and
 *    points where mesh edges cross a bound. New points lie on mesh edges and are shared by every
 *    tetrahedron around the edge.
 * 3. Tetrahedralisation: each polytope is split by pulling from its vertex of smallest global name
 *    (names come from the input point ids only), which splits every face the same way from both
 *    sides: the patches of neighbouring leaves conform.
 *
 * Interaction. The isosurface-only hierarchy is built once per input array (in milliseconds) and
 * kept between executions; changing ThresholdRange, Tolerance, MaximumNumberOfTetrahedra or the
 * region re-runs only the extraction (errors measured for the same range are reused).
 *
 * Options:
 * - ThresholdRange (α, β): data units, α < β (default 0, 1; ParaView's panel starts at the array's
 *   range).
 * - Tolerance: world units, >= 0 (default 0; ParaView's panel starts at two and a half voxel
 *   diagonals, as for vtkAdaptiveIsosurface).
 * - MaximumNumberOfTetrahedra: 0 = no limit; otherwise the tolerance is raised until the output fits.
 * - UseRegionOfInterest / RegionOfInterest: Tolerance applies only inside the box.
 *
 * Output (vtkUnstructuredGrid of VTK_TETRA, double-precision points): every input point array,
 * copied at sample points and interpolated linearly along the mesh edge at new points; cell data
 * "Level" (the bisection depth of the adaptive-mesh leaf each tetrahedron was cut from, 0 = the six
 * base tetrahedra); field data "ErrorBound" (largest isosurface error, world units, of the diamonds
 * carrying a bounding surface), "Tolerance", "RelativeTolerance", "ReachedTolerance" (the tolerance
 * refined for, above Tolerance when the budget raised it), "NumberOfTetrahedra", "NumberOfPoints"
 * and "NumberOfLeaves" (leaves of the adaptive mesh that meet the range).
 *
 * Errors (vtkErrorMacro, empty output, no crash): a NaN/Inf bound or ThresholdRange[0] >=
 * ThresholdRange[1]; negative or non-finite Tolerance; negative MaximumNumberOfTetrahedra; 2-D
 * images; no point scalars; multi-component arrays; NaN/Inf samples; a region of interest outside
 * the image; an oriented image. A range that misses the data range gives a warning and an empty
 * output.
 *
 * Distributed data (MPI): every process extracts the interval volume of its own piece; pieces
 * refine their shared plane independently, so neighbouring pieces may not conform along it.
 *
 * @sa
 * vtkAdaptiveIsosurface, vtkAdaptiveTetrahedra, ParaView's Iso Volume (two table-based clips at full
 * resolution)
 */

#ifndef vtkAdaptiveIntervalVolume_h
#define vtkAdaptiveIntervalVolume_h

#include "vtkDiamondsModule.h" // For export macro
#include "vtkUnstructuredGridAlgorithm.h"

class vtkImageData;
class vtkMultiProcessController;

class VTKDIAMONDS_EXPORT vtkAdaptiveIntervalVolume : public vtkUnstructuredGridAlgorithm
{
public:
  static vtkAdaptiveIntervalVolume* New();
  vtkTypeMacro(vtkAdaptiveIntervalVolume, vtkUnstructuredGridAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * The range (α, β) of the interval volume, data units, α < β. Default (0, 1).
   */
  vtkSetVector2Macro(ThresholdRange, double);
  vtkGetVector2Macro(ThresholdRange, double);
  ///@}

  ///@{
  /**
   * Isosurface error tolerance of both bounding surfaces, world units, >= 0. 0 (default) gives
   * the full-resolution interval volume.
   */
  vtkSetMacro(Tolerance, double);
  vtkGetMacro(Tolerance, double);
  ///@}

  /**
   * Tolerance divided by the diagonal of the whole input image at the last execution.
   */
  vtkGetMacro(RelativeTolerance, double);

  ///@{
  /**
   * Upper bound on the number of output tetrahedra; 0 (default) means no limit.
   */
  vtkSetMacro(MaximumNumberOfTetrahedra, vtkIdType);
  vtkGetMacro(MaximumNumberOfTetrahedra, vtkIdType);
  ///@}

  ///@{
  /**
   * When on, Tolerance applies only inside RegionOfInterest. Default off.
   */
  vtkSetMacro(UseRegionOfInterest, vtkTypeBool);
  vtkGetMacro(UseRegionOfInterest, vtkTypeBool);
  vtkBooleanMacro(UseRegionOfInterest, vtkTypeBool);
  ///@}

  ///@{
  /**
   * The region of interest as world bounds (xmin, xmax, ymin, ymax, zmin, zmax).
   */
  vtkSetVector6Macro(RegionOfInterest, double);
  vtkGetVector6Macro(RegionOfInterest, double);
  ///@}

  /**
   * Which hierarchy the interval volume is extracted from (Weiss & De Floriani, "Isodiamond
   * Hierarchies"): HIERARCHY_FULL (default) the diamond hierarchy of the whole image, read from the
   * samples; HIERARCHY_RELEVANT or HIERARCHY_MINIMAL an isodiamond hierarchy (RI: active and
   * relevant isodiamonds, §6; MI: active and creation isodiamonds only, §7) of ThresholdRange, built
   * when the range (or the input) changes and kept, from which every Tolerance is extracted
   * without reading the samples. It stores the full hierarchy's split set at each rung of a ladder
   * of tolerances (4 % down to 0.0625 % of the image diagonal, halving, then 0): a Tolerance gives
   * the tetrahedra Full gives at the finest rung at or below it (exactly Full's at a rung, finer
   * between rungs); MaximumNumberOfTetrahedra picks the finest rung at or above Tolerance that
   * fits. New points lie at the stored crossing positions (quantised to 1/256 of their edge, at
   * most 1/512 of the edge from Full's), and the input point arrays are interpolated there. Not
   * available with it (error): a region of interest.
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
   * Number of times this filter has built a diamond hierarchy.
   */
  vtkGetMacro(NumberOfHierarchyBuilds, vtkIdType);

  /**
   * Number of times this filter has built an isodiamond hierarchy (Hierarchy RELEVANT or MINIMAL:
   * once per range, choice or input; none when only Tolerance or the budget changed).
   */
  vtkGetMacro(NumberOfIsodiamondBuilds, vtkIdType);

  /**
   * Bytes of the hierarchy in use (also field data "HierarchyMemorySize"). Full: the processed
   * array's values, which the extraction reads again (a reference to the input array, not a
   * copy), plus what it keeps between executions (errors, gradients, brick ranges). Relevant or
   * Minimal: the isodiamond hierarchy.
   */
  vtkIdType GetHierarchyMemorySize();

  /**
   * Frees the cached hierarchy and the reference to the input array.
   */
  void ReleaseHierarchy();

protected:
  vtkAdaptiveIntervalVolume();
  ~vtkAdaptiveIntervalVolume() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  // RequestData on more than one rank: every rank's share of the serial interval volume.
  int RequestDistributed(vtkMultiProcessController* controller, vtkInformationVector** inputVector,
    vtkImageData* input, vtkUnstructuredGrid* output);

  double ThresholdRange[2];
  double Tolerance;
  double RelativeTolerance;
  vtkIdType MaximumNumberOfTetrahedra;
  vtkTypeBool UseRegionOfInterest;
  double RegionOfInterest[6];
  int Hierarchy;
  vtkIdType NumberOfHierarchyBuilds;
  vtkIdType NumberOfIsodiamondBuilds;

private:
  vtkAdaptiveIntervalVolume(const vtkAdaptiveIntervalVolume&) = delete;
  void operator=(const vtkAdaptiveIntervalVolume&) = delete;

  class vtkInternals;
  vtkInternals* Internals;
};

#endif
