/**
 * @class   vtkAdaptiveTetrahedra
 * @brief   adaptive, conforming tetrahedral mesh of an image by longest-edge bisection
 *
 * vtkAdaptiveTetrahedra converts a 3-D vtkImageData into a vtkUnstructuredGrid made only of
 * VTK_TETRA cells whose piecewise-linear interpolation of one point-data array stays within an
 * absolute Tolerance of every input sample. Flat regions are covered by a few large
 * tetrahedra, detailed regions by small ones; Tolerance 0 reproduces every sample exactly. Every
 * output point is an input sample, so every input point-data array is passed through unchanged
 * (same names, types, components; values copied, never interpolated).
 *
 * The mesh is built by longest-edge bisection (LEB) of the cube containing the image, organised
 * as a hierarchy of diamonds:
 *
 * 1. Lattice. The image is embedded at the corner of a virtual (2^L+1)^3 lattice, the smallest
 *    one holding it. The root cube is split into six tetrahedra around its major diagonal
 *    (Gregorski et al. 2002, "Recursive Tetrahedral Meshes for Scientific Visualization", §3).
 *    Bisecting a tetrahedron at the midpoint of its longest edge produces three similarity classes
 *    of tetrahedra (phases 0, 1, 2: new vertex at a cube centre, a face centre, an edge midpoint),
 *    so every vertex of every tetrahedron is a lattice point, i.e. an input sample.
 * 2. Diamonds. The tetrahedra sharing a longest edge (the spine) must be bisected together or the
 *    mesh cracks; such a cluster (6, 4 or 8 tetrahedra) is a diamond (Gregorski §3.1; Weiss &
 *    De Floriani, "Isodiamond Hierarchies", §4). A diamond is identified by its central vertex,
 *    the midpoint of its spine; its level, type, vertices, parents and children follow from the
 *    bits of that vertex's coordinates (Weiss & De Floriani §4, Eq. 1), so the hierarchy needs no
 *    pointers: its per-diamond data is an array parallel to the samples.
 * 3. Exact error. For every diamond the build pass enumerates the integer lattice points inside
 *    each of its tetrahedra (Marchesin et al., "3D ROAM for Scalable Volume Visualization", §4.1;
 *    here row by row along x, each row cut by the four face planes in exact integer arithmetic)
 *    and stores the maximum |sample - linear interpolant|. This is the
 *    exact error over the samples, not an estimate, stored rounded up (an upper bound within
 *    0.8 %, and 0 exactly when the error is 0). The hierarchy costs 4 bytes per input point.
 * 4. Selective refinement. A query starts from the coarsest mesh that fits the image and splits
 *    every diamond whose error exceeds Tolerance, after splitting its unsplit parents (the closure
 *    of Gregorski §4), until every diamond meets Tolerance. With MaximumNumberOfTetrahedra the
 *    diamond of largest error goes first and the query stops before the next split would exceed
 *    the budget. Because a diamond is split only with all its parents, the result is always
 *    conforming: no cracks, no hanging vertices.
 *
 * Domain handling: image dimensions need not be 2^k+1. Tetrahedra that cross a far face of the
 * image are always refined until they lie inside it, and tetrahedra outside are dropped, so the
 * mesh covers exactly the image bounds with no holes and no points outside. The price is a band
 * of small tetrahedra along far faces whose size is not 2^k+1 (e.g. 256 points); 2^k+1 points per
 * axis has no such band. A budget below this minimal "base mesh" yields the base mesh.
 *
 * The hierarchy is built once per input: one pass over the samples, its cost grows with the number
 * of points. A query does not read the samples again; its cost grows with the number of
 * tetrahedra it outputs. The filter keeps the hierarchy between executions and rebuilds
 * it only when the input array, its values (MTime), its name, or the image geometry (extent,
 * origin, spacing) change. Changing Tolerance, MaximumNumberOfTetrahedra or the region of interest
 * re-runs only the query; GetNumberOfHierarchyBuilds() counts the builds.
 *
 * Output: points in double precision at the input sample positions; cells VTK_TETRA, positively
 * oriented; all input point data passed through; cell data "BisectionDepth" (unsigned char, 0 =
 * the six root tetrahedra; Gregorski's level is BisectionDepth / 3, the phase BisectionDepth % 3) and
 * "ApproximationError" (float, the error bound of the tetrahedron's diamond, in data units); field
 * data "Tolerance", "NumberOfTetrahedra" and "MaximumError" (the largest ApproximationError),
 * next to the input's field data.
 *
 * Distributed data (MPI: pvbatch, pvserver): when the global vtkMultiProcessController has more
 * than one process, the ranks compute the serial mesh together and each outputs its share: the
 * union of their outputs is exactly the output of one process on the whole image (same
 * tetrahedra, depths and errors), each tetrahedron on exactly one rank (the one whose piece holds
 * its centroid, cells half-open), with no hanging faces between pieces. The lattice is that of the
 * whole extent; each rank computes the errors of the diamonds meeting its piece from its samples,
 * a halo of 8 or more layers and a sublattice of the whole image fetched from the other ranks; the
 * errors of large diamonds spanning several pieces are combined by a maximum over the ranks; the
 * refinement with closure runs in rounds in which each rank sends the diamonds it split to the
 * ranks whose pieces their children meet, until no rank has anything to send (see
 * diamonds::hierarchy::piece in the Rust core). Point data of points held by other ranks is
 * fetched from them. The output carries the point array "GlobalPointIds" (the point's index in
 * the whole extent, set as the global ids) and field data "TetrahedraPerRank", "SecondsPerRank",
 * "BytesSentPerRank", "ExchangeSecondsPerRank" and "PeakMemoryPerRank" (bytes of resident memory;
 * one value per rank each, for load balance) and "RefinementRounds"; "NumberOfTetrahedra" and
 * "MaximumError" are totals over the ranks. MaximumNumberOfTetrahedra is refused on more than one
 * rank (a budget orders splits across all pieces). The filter asks its input for no ghost levels
 * (it fetches what it needs), and an empty piece takes part and outputs nothing. An error on one
 * rank stops every rank with an error (no rank waits forever).
 *
 * Limitations and errors (reported with vtkErrorMacro, empty output, no crash): fewer than 2
 * points along an axis (2-D images); no point scalars (cell data only: apply Cell Data to Point
 * Data first); a multi-component array (needs a single-component array: use Calculator to
 * extract a component); NaN or Inf samples; negative Tolerance or MaximumNumberOfTetrahedra;
 * a region of interest outside the image bounds; an image of more than 2^32 points, or whose
 * hierarchy would not fit in the available memory (both checked before allocating); an oriented
 * image (non-identity direction
 * matrix). Arrays of 8-, 16- and 32-bit integers, float and double are read in place; 64-bit
 * integer arrays are converted to double with a warning (refused if a value exceeds 2^53, where
 * the conversion is inexact).
 *
 * Progress is reported through UpdateProgress (hierarchy build, then the query, then the
 * output); AbortExecute / CheckAbort interrupts the build and leaves the output empty; under
 * MPI an abort on one rank ends every rank's execution. The flag is cleared by the next execution
 * after a property or the input changed.
 *
 * The core of this filter is written in Rust (crate diamonds-core) and reached through one cxx
 * bridge (crate diamonds-bridge); the build runs on a thread pool of its own, independent of
 * VTK's SMP backend.
 *
 * @sa
 * vtkDataSetTriangleFilter (ParaView "Tetrahedralize": the non-adaptive 5 or 6 tetrahedra per
 * voxel), vtkUnstructuredGridQuadricDecimation, vtkDecimatePro, vtkFlyingEdges3D,
 * vtkProjectedTetrahedraMapper
 */

#ifndef vtkAdaptiveTetrahedra_h
#define vtkAdaptiveTetrahedra_h

#include "vtkDiamondsModule.h" // For export macro
#include "vtkUnstructuredGridAlgorithm.h"

class vtkImageData;
class vtkMultiProcessController;

class VTKDIAMONDS_EXPORT vtkAdaptiveTetrahedra : public vtkUnstructuredGridAlgorithm
{
public:
  static vtkAdaptiveTetrahedra* New();
  vtkTypeMacro(vtkAdaptiveTetrahedra, vtkUnstructuredGridAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * Absolute tolerance, in the units of the processed array: every input sample differs from the
   * mesh's linear interpolation by at most this much. 0 reproduces every sample (lossless).
   * Must be >= 0. Default 1.0, which on typical 8-bit data (range 0-255) and on ParaView's Wavelet
   * (range about 37-277) keeps fine detail while collapsing smooth regions; for other data a
   * good start is 0.5 %-1 % of the array's range.
   */
  vtkSetMacro(Tolerance, double);
  vtkGetMacro(Tolerance, double);
  ///@}

  ///@{
  /**
   * Upper bound on the number of output tetrahedra; 0 (default) means no limit. When the budget
   * binds, the splits of largest error are made first, and Tolerance may not be met (the field
   * data MaximumError tells the error reached). A budget below the minimal mesh of the domain
   * (see the class comment) yields that minimal mesh. Must be >= 0.
   */
  vtkSetMacro(MaximumNumberOfTetrahedra, vtkIdType);
  vtkGetMacro(MaximumNumberOfTetrahedra, vtkIdType);
  ///@}

  ///@{
  /**
   * When on, Tolerance applies only to diamonds that touch RegionOfInterest; the mesh stays
   * coarse elsewhere (only the refinement needed for conformity). Default off.
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

  /**
   * Number of times this filter has built a diamond hierarchy (one per execution whose input
   * array or geometry changed; none when only Tolerance, the budget or the region changed).
   */
  vtkGetMacro(NumberOfHierarchyBuilds, vtkIdType);

  /**
   * Bytes held by the cached hierarchy (0 when none is cached).
   */
  vtkIdType GetHierarchyMemorySize();

  /**
   * Frees the cached hierarchy; the next execution rebuilds it.
   */
  void ReleaseHierarchy();

protected:
  vtkAdaptiveTetrahedra();
  ~vtkAdaptiveTetrahedra() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  double Tolerance;
  vtkIdType MaximumNumberOfTetrahedra;
  vtkTypeBool UseRegionOfInterest;
  double RegionOfInterest[6];
  vtkIdType NumberOfHierarchyBuilds;

private:
  // RequestData on more than one rank: the serial mesh, partitioned (see the class comment).
  int RequestDistributed(vtkMultiProcessController* controller, vtkInformationVector** inputVector,
    vtkImageData* input, vtkUnstructuredGrid* output);

  vtkAdaptiveTetrahedra(const vtkAdaptiveTetrahedra&) = delete;
  void operator=(const vtkAdaptiveTetrahedra&) = delete;

  class vtkInternals;
  vtkInternals* Internals;
};

#endif
