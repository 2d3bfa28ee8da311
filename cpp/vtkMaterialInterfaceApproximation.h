/**
 * @class   vtkMaterialInterfaceApproximation
 * @brief   adaptive tetrahedral mesh of multi-material data with linear interfaces and ghost values
 *
 * vtkMaterialInterfaceApproximation approximates multi-material simulation output (per-material
 * volume fractions plus mixed-cell fields such as density, as CTH, ALE and Eulerian hydro codes
 * write them) by an adaptive, conforming tetrahedral mesh in which
 * - every material interface is, inside each tetrahedron, the zero set of a linear signed-distance
 *   function (one value per vertex and interface), refined until every vertex of the interface
 *   mesh lies within InterfaceTolerance (world units) of its approximating plane, and
 * - every field is carried once per material: at a vertex inside material m the value is m's own,
 *   elsewhere it is a *ghost value*, taken from the closest interface point on m's side, so that
 *   each material's field is linear inside each tetrahedron and the field is discontinuous exactly
 *   at the approximated interface (no smearing of, say, steel density into void). The mesh is
 *   refined until each material's linear field is within FieldTolerance (data units) of every input
 *   sample of that material.
 *
 * The method is Gregorski et al. 2002, "Recursive Tetrahedral Meshes for Scientific Visualization",
 * §5 (5.1-5.5): interface meshes (reconstructed from the fractions by multi-label Surface Nets, or
 * given on input port 1), signed distances at tetrahedron vertices from a spatial index of the
 * interface meshes (§5.2.1), ghost values (§5.2.3), and refinement of a longest-edge-bisection
 * (diamond) mesh first to the interface tolerance, then to the field tolerance (§5.3). Errors are
 * measured exactly at the input samples (§5.4), not with the nested bound of Eq. (1)-(2). Inside a
 * tetrahedron the material at a point is the one of smallest interpolated signed distance to its
 * material boundary, so the approximated interfaces are crack-free, junctions of three materials
 * included.
 *
 * Input port 0: vtkImageData (axis-aligned) or vtkRectilinearGrid whose coordinates are uniformly
 * spaced along each axis (a non-uniform one is refused: apply Resample To Image first), at least 2
 * points along every axis, with one single-component volume-fraction array per material (point or
 * cell data; cell data are converted to point data with vtkCellDataToPointData, the average of the
 * cells around each point) and optionally fields to approximate (point or cell data, likewise):
 * mixed-cell fields (FieldArrays) and per-material fields (MaterialFieldArrays, "<field> for
 * <material>" or "<field> (<material>)": the field's value inside that material, used as that
 * material's own value; a field given only per material gets the mixed values sum of fraction x
 * per-material value). Fractions must lie in [0, 1] and sum to 1 at every point (to 1 %).
 *
 * Input port 1 (optional): vtkPolyData of triangles, the interface meshes to use instead of the
 * reconstruction: a 2-component integer cell array (InterfaceMaterialsArray, default
 * "InterfaceMaterials") names the two materials on either side of each triangle (indices into
 * VolumeFractionArrays), and the cell normals, else the point normals, else the triangles' counter-
 * clockwise winding tell the direction: from the first material into the second. Triangles whose
 * winding disagrees with the normals are flipped (in the Rust bridge).
 *
 * Output port 0 (vtkUnstructuredGrid, "Tetrahedra"): VTK_TETRA cells.
 * - Point data: "Material" (int, the material of the vertex); "SignedDistance <A>|<B>" (float) per
 *   interface pair, positive on B's side; "SignedDistance <M>" (float) per material, negative
 *   inside M; "<field>" (float) per field, the field resampled at the vertex; with UseGhostValues,
 *   "<field> (<M>)" per field and material (M's own value at vertices of M, a ghost value elsewhere)
 *   and "IsGhost (<M>)" (unsigned char, 1 where the values of M are ghost values, i.e. Material != M).
 * - Cell data: "InterfaceError" (world units), "FieldError" (data units), "Materials" (bit mask of the
 *   materials present), "NumberOfMaterials", "BisectionDepth" (bisection depth).
 * - Field data: "InterfaceTolerance", "FieldTolerance", "MaximumInterfaceError", "MaximumFieldError",
 *   "NumberOfTetrahedra", "InterfaceTetrahedra" (after the interface pass alone),
 *   "UseGhostValues", and the string arrays "MaterialNames", "InterfaceNames", "FieldNames".
 * Material names come from the fraction array names without "Volume Fraction for " / " Volume
 * Fraction" and the like ("Volume Fraction for Armor Plate" -> "Armor Plate").
 *
 * Output port 1 (vtkPolyData, "Interfaces"): the approximated interfaces as polygons (the zero sets
 * inside each tetrahedron; points shared across tetrahedra, crack-free), oriented from MaterialA into
 * MaterialB, with cell data "Interface" (index of the pair in InterfaceNames), "MaterialA",
 * "MaterialB" (int), and field data "MaterialNames" and "InterfaceNames".
 *
 * Output port 2 (vtkPolyData, "Slice"): the cut of the mesh by the plane SliceOrigin / SliceNormal,
 * split at the approximated interfaces, with cell data "Material" (int; -1 without ghost values, where
 * the cut shows the mixed field) and point data "<field>" (each polygon carries its own material's
 * field, as Gregorski's Figures 15-16).
 *
 * Interaction. The prepared model (classification, interface meshes, spatial index) is built once
 * and kept while the arrays (pointer, MTime, name), the grid and the interface meshes do not change;
 * GetNumberOfModelBuilds() counts the builds. The refined mesh is kept too while the tolerances and
 * UseGhostValues do not change, so moving the slice plane only re-slices;
 * GetNumberOfRefinements() counts the refinements.
 *
 * Errors (vtkErrorMacro, all outputs empty, no crash): a missing array (the message lists the point
 * and cell arrays), a per-material array whose name matches no field and material (the message
 * lists the accepted names), fewer than 2 fraction arrays, a multi-component array, an array listed twice,
 * fractions out of [0, 1] or not summing to 1, NaN or infinite values, negative or non-finite
 * tolerances, a zero or non-finite slice normal, 2-D images, oriented images, non-uniform
 * rectilinear grids, bad interface meshes. An empty input gives empty outputs without an error.
 *
 * Distributed data (MPI: pvbatch, pvserver): when the global vtkMultiProcessController has more
 * than one process, the union of the ranks' outputs is exactly what one process computes from the
 * whole input (same tetrahedra, interface polygons and slice polygons with their arrays, up to order
 * and point ids), each cell on exactly one rank (the one whose piece's half-open cell box holds the
 * cell's centroid), so no hanging faces and crack-free interfaces across the pieces' seams. Every
 * rank with a piece gathers every rank's piece of the selected arrays (and of a rectilinear grid's
 * coordinates; cell data is converted on the whole input) and computes the whole approximation,
 * then outputs its share: memory and work per rank are the serial ones. Each output carries the
 * point array "GlobalPointIds" (the point's index in the whole output); the tetrahedra carry field
 * data "TetrahedraPerRank", "SecondsPerRank", "BytesSentPerRank", "ExchangeSecondsPerRank" and
 * "PeakMemoryPerRank"; "NumberOfTetrahedra" and "NumberOfPolygons" are the totals. An empty piece
 * takes part and outputs nothing.
 *
 * Progress: model build, then refinement (reported by the core), then the outputs; AbortExecute
 * stops the refinement and leaves the outputs empty; under MPI an abort on one rank ends every
 * rank's execution. The flag is cleared by the next execution after a property or the input
 * changed.
 *
 * The core is written in Rust (crate diamonds-core, module material) and reached through the cxx
 * bridge (crate diamonds-bridge); this class only reads arrays, calls the bridge and builds VTK
 * output.
 *
 * @sa
 * vtkYoungsMaterialInterface (per-cell planes, not continuous across cells), vtkAdaptiveTetrahedra
 */

#ifndef vtkMaterialInterfaceApproximation_h
#define vtkMaterialInterfaceApproximation_h

#include "vtkDiamondsModule.h" // For export macro
#include "vtkUnstructuredGridAlgorithm.h"

class vtkPolyData;

class VTKDIAMONDS_EXPORT vtkMaterialInterfaceApproximation : public vtkUnstructuredGridAlgorithm
{
public:
  static vtkMaterialInterfaceApproximation* New();
  vtkTypeMacro(vtkMaterialInterfaceApproximation, vtkUnstructuredGridAlgorithm);
  void PrintSelf(ostream& os, vtkIndent indent) override;

  ///@{
  /**
   * The volume-fraction arrays, one per material (at least 2), point or cell data of input 0. The
   * order defines the material indices (0, 1, ...). When the list is empty, every single-component
   * array whose name contains "fraction" (any case) is used, point data first.
   */
  void SetNumberOfVolumeFractionArrays(int n);
  int GetNumberOfVolumeFractionArrays();
  void SetVolumeFractionArray(int i, const char* name);
  const char* GetVolumeFractionArray(int i);
  void AddVolumeFractionArray(const char* name);
  void ClearVolumeFractionArrays();
  ///@}

  ///@{
  /**
   * The fields to approximate (mixed-cell values such as density), point or cell data of input 0;
   * may be empty (interfaces only).
   */
  void SetNumberOfFieldArrays(int n);
  int GetNumberOfFieldArrays();
  void SetFieldArray(int i, const char* name);
  const char* GetFieldArray(int i);
  void AddFieldArray(const char* name);
  void ClearFieldArrays();
  ///@}

  ///@{
  /**
   * Optional per-material values of the fields, point or cell data of input 0 (converted like the
   * fields): the value of a field inside one material (say the density of steel, where the mixed
   * field has the density of the steel and void mixture). Each array is matched by name: "<field> for
   * <material>" or "<field> (<material>)", <material> a material name (see MaterialNames below); an
   * array that matches nothing is an error listing the accepted names. A <field> that is none of
   * FieldArrays defines that field (after FieldArrays, in order of first appearance), given only
   * per material.
   * With ghost values, a material's own value at its samples (its vertex values, ghost values and
   * field error) is then its per-material value instead of the mixed one; plain interpolation
   * ignores them. A name of FieldArrays that is not an array of the input but has per-material
   * arrays is a field given only per material: its mixed values are the sum over the materials of
   * fraction x per-material value (the materials without an array count 0). CTH example:
   * MaterialFieldArrays "Mass for Armor Plate", "Mass for Body, Nose" gives a field "Mass" (void:
   * none, 0), as FieldArrays "Mass" with them would.
   */
  void SetNumberOfMaterialFieldArrays(int n);
  int GetNumberOfMaterialFieldArrays();
  void SetMaterialFieldArray(int i, const char* name);
  const char* GetMaterialFieldArray(int i);
  void AddMaterialFieldArray(const char* name);
  void ClearMaterialFieldArrays();
  ///@}

  ///@{
  /**
   * Largest distance, in world units, from a vertex of an interface mesh to the plane that
   * approximates that interface in its tetrahedron. Must be >= 0 (0 refines interfaces to the
   * finest level). Default 0.15 (the paper's value for its impact data set, whose grid spacing is
   * about 0.4); ParaView's panel starts at about one cell diagonal of the input (its diagonal over
   * the cube root of its number of cells).
   */
  vtkSetMacro(InterfaceTolerance, double);
  vtkGetMacro(InterfaceTolerance, double);
  ///@}

  ///@{
  /**
   * Largest deviation, in data units and for every field, of a sample of a material from that
   * material's linear field (with ghost values) or from the linear interpolation of the mixed field
   * (without). Must be >= 0. Default 3 (the paper's density tolerance for its impact data set).
   * Ignored without fields (FieldArrays or fields defined by MaterialFieldArrays).
   */
  vtkSetMacro(FieldTolerance, double);
  vtkGetMacro(FieldTolerance, double);
  ///@}

  ///@{
  /**
   * On (default): one linear field per material with ghost values, discontinuous at the
   * interfaces. Off: plain linear interpolation of the mixed fields (for comparison; needs far more
   * tetrahedra near interfaces for the same FieldTolerance).
   */
  vtkSetMacro(UseGhostValues, vtkTypeBool);
  vtkGetMacro(UseGhostValues, vtkTypeBool);
  vtkBooleanMacro(UseGhostValues, vtkTypeBool);
  ///@}

  ///@{
  /**
   * The plane of output port 2: a point on it and its normal (any non-zero length). Default
   * origin (0, 0, 0), normal (1, 0, 0).
   */
  vtkSetVector3Macro(SliceOrigin, double);
  vtkGetVector3Macro(SliceOrigin, double);
  vtkSetVector3Macro(SliceNormal, double);
  vtkGetVector3Macro(SliceNormal, double);
  ///@}

  ///@{
  /**
   * Name of the 2-component integer cell array of input 1 that names the two materials of each
   * interface triangle. Default "InterfaceMaterials".
   */
  vtkSetStringMacro(InterfaceMaterialsArray);
  vtkGetStringMacro(InterfaceMaterialsArray);
  ///@}

  /**
   * The optional interface meshes (input port 1).
   */
  void SetInterfaceMeshesData(vtkPolyData* meshes);
  void SetInterfaceMeshesConnection(vtkAlgorithmOutput* output);

  /**
   * Number of times the material model (classification, interface meshes, spatial index) was
   * built; not incremented when only tolerances, UseGhostValues or the slice plane change.
   */
  vtkGetMacro(NumberOfModelBuilds, vtkIdType);

  /**
   * Number of refinements; not incremented when only the slice plane changes.
   */
  vtkGetMacro(NumberOfRefinements, vtkIdType);

  /**
   * Frees the kept model and mesh; the next execution rebuilds.
   */
  void ReleaseModel();

protected:
  vtkMaterialInterfaceApproximation();
  ~vtkMaterialInterfaceApproximation() override;

  int FillInputPortInformation(int port, vtkInformation* info) override;
  int FillOutputPortInformation(int port, vtkInformation* info) override;
  int RequestUpdateExtent(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;
  int RequestData(vtkInformation*, vtkInformationVector**, vtkInformationVector*) override;

  double InterfaceTolerance;
  double FieldTolerance;
  vtkTypeBool UseGhostValues;
  double SliceOrigin[3];
  double SliceNormal[3];
  char* InterfaceMaterialsArray;
  vtkIdType NumberOfModelBuilds;
  vtkIdType NumberOfRefinements;

private:
  vtkMaterialInterfaceApproximation(const vtkMaterialInterfaceApproximation&) = delete;
  void operator=(const vtkMaterialInterfaceApproximation&) = delete;

  class vtkInternals;
  vtkInternals* Internals;
};

#endif
