//! # diamonds-bridge
//!
//! The one boundary between the Diamonds core (crate `diamonds-core`, lib `diamonds`) and C++.
//! It is the only Rust staticlib linked into the VTK module `Diamonds::Filters` (and so
//! into the ParaView plugin): linking two Rust staticlibs into one binary duplicates the Rust
//! runtime symbols.
//!
//! What crosses, and nothing else:
//! - in: the image geometry ([`ffi::GridSpec`]), the samples as raw bytes plus a type tag
//!   ([`ffi::ScalarType`]; the bytes are reinterpreted in place, never copied), a progress
//!   observer implemented in C++ (`include/progress.h`), and the query parameters
//!   ([`ffi::QuerySpec`] for a mesh; the isovalues as a slice plus [`ffi::IsoSpec`] for an
//!   isosurface, which also reads the samples again);
//! - out: an opaque [`Hierarchy`] the filters keep between executions (`rust::Box<Hierarchy>`), an
//!   opaque [`IsoState`] kept next to it (the adaptive mesh of the last isosurface query, see
//!   `diamonds::IsoState`), an opaque [`MeshPlan`] (a query's mesh, counted) whose arrays the core
//!   writes straight into the VTK arrays C++ allocates with their exact sizes and hands over as
//!   mutable slices (no copy on either side), an opaque [`Mesh`] (carrier tetrahedra) and an opaque
//!   [`Surface`] whose arrays C++ reads as slices;
//! - interval volumes ([`interval`], for `vtkAdaptiveIntervalVolume`): an [`ffi::IntervalSpec`] and
//!   the samples again, with the [`IsoState`] kept next to the hierarchy; out an opaque
//!   [`IntervalVolume`] whose arrays C++ reads as slices;
//! - material interfaces ([`material`], for `vtkMaterialInterfaceApproximation`): volume fractions
//!   and fields as `f32` slices added to a [`MaterialBuilder`], optional interface meshes as a
//!   triangle soup, out an opaque [`MaterialModel`] (kept between executions), [`MaterialMesh`] and
//!   [`PolygonMesh`].
//!
//! **No panic crosses.** An unwinding panic that reaches a C++ frame aborts the process, i.e. the
//! user's whole ParaView session. Every bridge function that can fail therefore runs its body
//! inside [`std::panic::catch_unwind`] (see [`guard`]) and returns `Result<_, String>`; cxx turns
//! the `Err` into a thrown `rust::Error` whose `what()` is the message, which the filter reports
//! with `vtkErrorMacro`. Plain getters of results checked when they were made (a slice, a number,
//! a flag: nothing that indexes, allocates or computes) are infallible: no `Result`, no guard, and
//! no try/catch in C++.

use std::any::Any;
use std::panic::{catch_unwind, AssertUnwindSafe};
use std::pin::Pin;
use std::sync::atomic::{AtomicU64, Ordering};

use diamonds::hierarchy::piece::PointBox;
use diamonds::validate::{check_isosurface_arrays, check_mesh_arrays};
use diamonds::{Grid, IsoQuery, IsoSurface, Query, ScalarSlice, TetMesh};

#[cxx::bridge(namespace = "diamonds::bridge")]
mod ffi {
    /// Geometry of the image (or image piece) handed to the core: points per axis (x fastest),
    /// world position of its first point, and spacing. Point ids in the result are relative to it.
    struct GridSpec {
        dims: [usize; 3],
        origin: [f64; 3],
        spacing: [f64; 3],
    }

    /// The sample types the core reads in place (VTK: unsigned char, signed char, unsigned short,
    /// short, unsigned int, int, float, double).
    enum ScalarType {
        U8,
        I8,
        U16,
        I16,
        U32,
        I32,
        F32,
        F64,
    }

    /// What a piece of a distributed tetrahedral mesh sends the others
    /// (`progressive_seam_messages`): its boundary points (indices into its points, for
    /// `build_progressive`), and for each rank `q` those inside rank `q`'s bounds (its own none):
    /// `counts[q]` values of `coordinates` (3 per point), the lists in rank order, as
    /// `SplitMessages`.
    struct SeamMessages {
        boundary: Vec<u32>,
        counts: Vec<usize>,
        coordinates: Vec<f64>,
    }

    /// The split diamonds one piece sends in a round of a distributed refinement: one list per
    /// piece (`counts[q]` values for piece `q`: its central vertices, three coordinates each; its
    /// own list empty), the lists concatenated in piece order in `centers`.
    struct SplitMessages {
        counts: Vec<usize>,
        centers: Vec<i32>,
    }

    /// The samples one piece of a distributed image asks of the others
    /// (`diamonds::hierarchy::piece::PieceLayout::requests`): `counts[q]` boxes for piece `q` (its
    /// own none), concatenated in piece order in `boxes`, seven values each (lo x, y, z, hi x, y,
    /// z, stride: the points lo + k·stride up to hi), and `points[q]` points in piece `q`'s boxes.
    /// The answers, each box's samples x fastest, concatenated in piece order, are the samples
    /// `build_piece_hierarchy` takes.
    struct SampleRequests {
        counts: Vec<usize>,
        points: Vec<usize>,
        boxes: Vec<u64>,
    }

    /// One selective-refinement query (see `diamonds::Query`).
    struct QuerySpec {
        /// Absolute tolerance in data units; 0 reproduces every sample.
        tolerance: f64,
        /// Maximum number of tetrahedra, 0 = no limit.
        max_tetrahedra: usize,
        /// Whether `region_of_interest` applies.
        use_region_of_interest: bool,
        /// World box `[xmin, xmax, ymin, ymax, zmin, zmax]`: refined to `tolerance` inside, coarse outside.
        region_of_interest: [f64; 6],
    }

    /// Where the points of a mesh go in world space: the point of grid index `(i, j, k)` (relative to
    /// the grid of the build) is at `origin + (first_index + (i, j, k)) × spacing` per axis — for a
    /// vtkImageData, its origin, the minima of its extent and its spacing (the formula of its bounds).
    struct PointFrame {
        origin: [f64; 3],
        first_index: [i64; 3],
        spacing: [f64; 3],
    }

    /// One isosurface query (see `diamonds::IsoQuery`); the isovalues are passed separately.
    struct IsoSpec {
        /// Isosurface error bound in world units; 0 = full resolution wherever the surface passes.
        tolerance: f64,
        /// Maximum number of triangles, 0 = no limit.
        max_triangles: usize,
        /// Whether `region_of_interest` applies.
        use_region_of_interest: bool,
        /// World box `[xmin, xmax, ymin, ymax, zmin, zmax]`: refined to `tolerance` inside, coarse outside.
        region_of_interest: [f64; 6],
        /// Point normals from the gradient (unit, toward increasing values).
        compute_normals: bool,
        /// Also return the tetrahedra that carry the surface.
        carrier_tetrahedra: bool,
    }

    /// One interval-volume query (see `diamonds::interval::IntervalQuery`).
    struct IntervalSpec {
        /// `[α, β]`, data units, `α < β`.
        range: [f64; 2],
        /// Isosurface error bound of both bounding surfaces, world units; 0 = full resolution.
        tolerance: f64,
        /// Maximum number of tetrahedra, 0 = no limit.
        max_tetrahedra: usize,
        /// Whether `region_of_interest` applies.
        use_region_of_interest: bool,
        /// World box `[xmin, xmax, ymin, ymax, zmin, zmax]`: refined to `tolerance` inside, coarse outside.
        region_of_interest: [f64; 6],
    }

    /// A numeric array of the input (for `select_material_arrays`).
    struct InputArrayInfo {
        name: String,
        components: usize,
        /// Cell data, else point data.
        cell: bool,
    }

    /// An input array to read; cell data is converted to point data first.
    #[derive(Debug)]
    struct SelectedArray {
        name: String,
        cell: bool,
    }

    /// A field to approximate and the array of its mixed values (unused when `from_materials`:
    /// computed from its per-material arrays).
    #[derive(Debug)]
    struct SelectedField {
        name: String,
        from_materials: bool,
        array: SelectedArray,
    }

    /// A per-material field array: field `field` inside material `material`.
    #[derive(Debug)]
    struct SelectedMaterialField {
        array: SelectedArray,
        field: usize,
        material: usize,
    }

    /// The arrays a material approximation reads (see `diamonds::material::selection`).
    #[derive(Debug)]
    struct ArraySelection {
        /// One name per material (the order of `fractions`).
        materials: Vec<String>,
        fractions: Vec<SelectedArray>,
        /// The selected fields, then those defined only by per-material arrays.
        fields: Vec<SelectedField>,
        material_fields: Vec<SelectedMaterialField>,
    }

    /// Which data of an output a named array belongs to.
    #[derive(Debug)]
    enum ArrayAssociation {
        Point,
        Cell,
        Field,
    }

    /// What a named output array is; its values are read with `OutputArrays::bytes`.
    struct OutputArrayInfo {
        name: String,
        association: ArrayAssociation,
        components: usize,
        value_type: ArrayType,
        /// Whether it is the active scalars of its data.
        active_scalars: bool,
    }

    /// The value type of a named output array.
    #[derive(Debug)]
    enum ArrayType {
        U8,
        I32,
        U32,
        I64,
        F32,
        F64,
    }

    /// One material refinement query (see `diamonds::material::MaterialQuery`).
    struct MaterialQuerySpec {
        /// Largest distance (world units) from an interface-mesh vertex to its approximating plane.
        interface_tolerance: f64,
        /// Largest deviation (data units) of a field at a sample of a material from that material's
        /// linear approximation.
        field_tolerance: f64,
        /// `false`: plain linear interpolation of the mixed fields (no per-material fields).
        ghost_values: bool,
    }

    /// How a progressive mesh is simplified (see `diamonds::progressive::Params`): the weights of
    /// Labsik et al.'s cost (§3.3) and the boundary handling.
    struct ProgressiveSpec {
        geometry_weight: f64,
        field_weight: f64,
        shape_weight: f64,
        /// Keep corners and feature edges, and removed boundary vertices within the tolerance.
        preserve_boundary: bool,
        /// Boundary tolerance as a fraction of the diagonal of `whole_bounds`.
        boundary_tolerance: f64,
        /// The bounds (xmin, xmax, ymin, ymax, zmin, zmax) of the whole mesh, every rank's piece
        /// under MPI.
        whole_bounds: [f64; 6],
    }

    /// A plane: a point on it and its normal (any length > 0).
    struct PlaneSpec {
        origin: [f64; 3],
        normal: [f64; 3],
    }

    /// One view-dependent query (see `diamonds::view::ViewQuery`): a perspective camera as
    /// vtkCamera describes it, the screen-space tolerance and the budget.
    struct ViewSpec {
        position: [f64; 3],
        focal_point: [f64; 3],
        view_up: [f64; 3],
        /// Vertical view angle in degrees.
        view_angle: f64,
        /// Viewport width and height in pixels.
        viewport: [u32; 2],
        /// Gregorski's screen-space error in pixels, ≥ 0.
        pixel_tolerance: f64,
        /// Maximum number of tetrahedra, 0 = no limit.
        max_tetrahedra: usize,
    }

    /// What one view update did (see `diamonds::view::FrameStats`).
    struct ViewFrame {
        splits: usize,
        merges: usize,
        tets: usize,
        /// The pixel tolerance reached (above the asked one when the budget bound).
        tolerance: f64,
        /// Diamonds whose view error was evaluated.
        evaluated: usize,
        seconds: f64,
    }

    unsafe extern "C++" {
        include!("diamonds-bridge/include/progress.h");

        /// Implemented by the filter; called on the calling thread only.
        type ProgressObserver;
        /// `fraction` in [0, 1]; returns false to abort.
        fn report(self: Pin<&mut ProgressObserver>, fraction: f64) -> bool;
    }

    unsafe extern "C++" {
        include!("diamonds-bridge/include/exchange.h");

        /// Implemented by a distributed filter; called on the calling thread only.
        type PieceExchange;
        /// Sends `bytes` to every rank; `all` gets every rank's, concatenated in rank order, and
        /// `lengths` their lengths. False when the ranks stop instead (a failure or an abort
        /// agreed on by all).
        fn all_gather(
            self: Pin<&mut PieceExchange>,
            bytes: &[u8],
            all: &mut Vec<u8>,
            lengths: &mut Vec<u64>,
        ) -> bool;
    }

    extern "Rust" {
        /// The diamond hierarchy of one image; owns its metadata (does not borrow the samples).
        /// Full (`build_hierarchy`: per-diamond records, serves `query` and `isosurface`) or
        /// isosurface-only (`build_isosurface_hierarchy`: serves `isosurface` alone).
        type Hierarchy;
        /// The tetrahedra carrying an isosurface (`take_carrier`).
        type Mesh;
        /// The triangles of one isosurface query (and, when asked, the tetrahedra carrying them).
        type Surface;
        /// What an isosurface filter keeps between queries: the adaptive mesh of the last query
        /// and the query it was refined for (`diamonds::IsoState`). It belongs to one
        /// hierarchy: [`isosurface`] forgets it when handed another one.
        type IsoState;

        /// Whether memory ran short during the last call on this thread: when that call failed,
        /// it may succeed once memory is free (not a failure to remember).
        fn ran_out_of_memory() -> bool;

        /// Builds the full hierarchy of `samples` (raw bytes of `scalar_type` values, x fastest) on
        /// `grid`: per-diamond records (2 bytes per point) computed with progress and abort.
        fn build_hierarchy(
            grid: &GridSpec,
            scalar_type: ScalarType,
            samples: &[u8],
            progress: Pin<&mut ProgressObserver>,
        ) -> Result<Box<Hierarchy>>;
        /// Builds the isosurface-only hierarchy of `samples` (no per-diamond records, no base mesh:
        /// milliseconds; `query` refuses it, `metadata_bytes` is 0).
        fn build_isosurface_hierarchy(
            grid: &GridSpec,
            scalar_type: ScalarType,
            samples: &[u8],
        ) -> Result<Box<Hierarchy>>;
        /// The adaptive tetrahedral mesh of one query, refined and counted but not written: the
        /// caller allocates its arrays exactly and has the core write them (`write_tets_*`,
        /// `write_points`, `gather_point_values`, `write_point_ids`), in parallel, with no copy in
        /// between. It belongs to the hierarchy that planned it.
        type MeshPlan;

        /// The part of the diamond hierarchy one piece of a distributed image needs (see
        /// `diamonds::hierarchy::piece`): the piece's diamond errors, the coarse ones combined
        /// across pieces by the filter.
        type PieceHierarchy;
        /// One query's split set on one piece, grown in rounds with the other pieces.
        type PieceRefinement;

        /// The boxes of samples the piece at `rank` of `pieces` (six extent values each, VTK
        /// order, relative to the whole extent) asks of each piece, from the first holding each.
        fn piece_requests(whole: &GridSpec, pieces: &[i64], rank: usize) -> Result<SampleRequests>;
        /// The indices (x fastest) among the points of the piece of extent `owned` of the points
        /// of `boxes` (seven values each, as in `SampleRequests`), box after box; an error when
        /// that piece does not hold them all.
        fn piece_box_local_ids(whole: &GridSpec, owned: &[i64], boxes: &[u64]) -> Result<Vec<i64>>;
        /// For each whole-grid point index of `ids`, the first piece of `pieces` (six extent
        /// values each) that holds it, or the number of pieces when none does.
        fn piece_point_owners(whole: &GridSpec, pieces: &[i64], ids: &[u64]) -> Result<Vec<u32>>;
        /// For each whole-grid point index of `ids`, its index (x fastest) among the points of the
        /// piece of extent `owned`, or -1 when that piece does not hold it.
        fn piece_local_ids(whole: &GridSpec, owned: &[i64], ids: &[u64]) -> Result<Vec<i64>>;

        /// The input points a piece's output takes its point data from, as a table: its own points
        /// first, then those other pieces hold (to fetch), each once; a row per point id asked
        /// about (`Surface::piece_sources`, `IntervalVolume::piece_sources`). A rank that puts the
        /// whole image together for the computation gathers only the processed array, not the
        /// others.
        type PointSources;
        /// The table's own points: their indices (x fastest) among the points of the piece,
        /// ascending.
        fn local(self: &PointSources) -> &[u64];
        /// The table's other points: their whole-grid indices, ascending.
        fn remote(self: &PointSources) -> &[u64];
        /// For each point id asked about, its row in the table (`local`'s, then `remote`'s).
        fn rows(self: &PointSources) -> &[u32];
        /// Builds the part of the hierarchy of the piece at `rank` of `pieces` from its own samples
        /// (`local`, its extent, x fastest) and `fetched`, the answers to its `piece_requests`
        /// in that order (same type).
        fn build_piece_hierarchy(
            whole: &GridSpec,
            pieces: &[i64],
            rank: usize,
            scalar_type: ScalarType,
            local: &[u8],
            fetched: &[u8],
            progress: Pin<&mut ProgressObserver>,
        ) -> Result<Box<PieceHierarchy>>;
        /// This piece's part of the coarse diamonds' errors: the element-wise maximum over all
        /// pieces goes to `combine_coarse_errors`.
        fn coarse_errors(self: &PieceHierarchy) -> &[f64];
        /// Takes the coarse errors combined over all pieces (before any refinement).
        fn combine_coarse_errors(self: &mut PieceHierarchy, combined: &[f64]) -> Result<()>;
        /// Starts refining for `query` (no budget) with what this piece can judge alone.
        fn start_refinement(
            self: &PieceHierarchy,
            query: &QuerySpec,
        ) -> Result<Box<PieceRefinement>>;
        /// The diamonds split here since the last call, addressed to the pieces whose reach they
        /// meet; `pieces` is every piece's extent.
        fn outgoing(
            self: &PieceHierarchy,
            refinement: &mut PieceRefinement,
            pieces: &[i64],
        ) -> Result<SplitMessages>;
        /// Inserts the diamonds the other pieces sent to this one (their `outgoing` lists for it,
        /// concatenated) and refines on; returns how many were new here.
        fn receive(
            self: &PieceHierarchy,
            refinement: &mut PieceRefinement,
            centers: &[i32],
        ) -> Result<usize>;
        /// Counts the tetrahedra this piece owns once no piece has anything to send (`pieces`:
        /// every piece's extent, this one's at `rank`; a tetrahedron belongs to the first piece
        /// whose cells hold its centroid) and their points (whole-grid indices), for the plan's
        /// writers: `write_piece_tets_i32`/`_i64`, `write_points`, `write_point_ids` and
        /// `gather_piece_point_values`.
        /// The plan takes the refinement.
        fn piece_plan(
            self: &PieceHierarchy,
            refinement: Box<PieceRefinement>,
            pieces: &[i64],
            rank: usize,
        ) -> Result<Box<MeshPlan>>;
        /// `write_tets_i32` for a plan of this piece (`piece_plan`), with the piece's errors.
        fn write_piece_tets_i32(
            self: &PieceHierarchy,
            plan: &MeshPlan,
            connectivity: &mut [i32],
            offsets: &mut [i32],
            depths: &mut [u8],
            errors: &mut [f32],
        ) -> Result<f64>;
        /// `write_tets_i64` for a plan of this piece (`piece_plan`), with the piece's errors.
        fn write_piece_tets_i64(
            self: &PieceHierarchy,
            plan: &MeshPlan,
            connectivity: &mut [i64],
            offsets: &mut [i64],
            depths: &mut [u8],
            errors: &mut [f32],
        ) -> Result<f64>;
        /// For a piece's plan: the whole-grid index of each of its points the piece does not
        /// hold, ascending (whose point data it fetches from the other pieces).
        fn piece_remote_point_ids(self: &MeshPlan) -> Result<Vec<u64>>;
        /// For a piece's plan: passes a point array through (`tuple_bytes` bytes per tuple) into
        /// `target`, from `local` (the piece's own array, one tuple per point of its extent) and
        /// `fetched` (one tuple per point of `piece_remote_point_ids`, in that order).
        fn gather_piece_point_values(
            self: &MeshPlan,
            local: &[u8],
            fetched: &[u8],
            tuple_bytes: usize,
            target: &mut [u8],
        ) -> Result<()>;
        /// Fails unless the extents `pieces` (every rank's) cover every point and every cell of
        /// the whole grid: what a rank checks before it puts the whole image together from them.
        fn piece_check_cover(whole: &GridSpec, pieces: &[i64]) -> Result<()>;
        /// `isosurface` on a rank that holds the whole image (this hierarchy and `samples` are
        /// the whole image's): the part of the surface the rank at `rank` of `pieces` (every
        /// rank's extent) owns — the triangles of the carrier tetrahedra whose centroid its cells
        /// hold, and those tetrahedra — with `global_point_ids`. Over all ranks, the serial
        /// surface, each triangle once. Every rank calls it with the same query and `state` (the
        /// same queries before; after a failure on any rank, every rank's `clear`); the
        /// ranks share the error measurement and the two-sided bound's check through `exchange`
        /// (`diamonds::isosurface::Partition`).
        #[allow(clippy::too_many_arguments)]
        fn isosurface_piece(
            self: &Hierarchy,
            state: &mut IsoState,
            scalar_type: ScalarType,
            samples: &[u8],
            isovalues: &[f64],
            spec: &IsoSpec,
            pieces: &[i64],
            rank: usize,
            exchange: Pin<&mut PieceExchange>,
        ) -> Result<Box<Surface>>;

        /// Refines for `query` and counts the mesh; cheap compared with the build.
        fn plan_mesh(self: &Hierarchy, query: &QuerySpec) -> Result<Box<MeshPlan>>;
        /// Number of tetrahedra of the planned mesh.
        fn number_of_tetrahedra(self: &MeshPlan) -> usize;
        /// Number of points of the planned mesh.
        fn number_of_points(self: &MeshPlan) -> usize;
        /// Writes the tetrahedra of `plan` (planned by this hierarchy) with 32-bit ids: 4 point
        /// indices each (positively oriented, VTK_TETRA order), offsets `4 i` (tets + 1 of them),
        /// bisection depths and errors; returns the largest error. Every slice must have exactly the
        /// size the mesh needs (4 × tets, tets + 1, tets, tets).
        fn write_tets_i32(
            self: &Hierarchy,
            plan: &MeshPlan,
            connectivity: &mut [i32],
            offsets: &mut [i32],
            depths: &mut [u8],
            errors: &mut [f32],
        ) -> Result<f64>;
        /// `write_tets_i32` with 64-bit ids.
        fn write_tets_i64(
            self: &Hierarchy,
            plan: &MeshPlan,
            connectivity: &mut [i64],
            offsets: &mut [i64],
            depths: &mut [u8],
            errors: &mut [f32],
        ) -> Result<f64>;
        /// Writes three world coordinates per point (3 × points values).
        fn write_points(self: &MeshPlan, frame: &PointFrame, xyz: &mut [f64]) -> Result<()>;
        /// Copies a point array through: `source` holds one tuple of `tuple_bytes` bytes per grid
        /// point, `target` gets one per mesh point (points × `tuple_bytes` bytes).
        fn gather_point_values(
            self: &MeshPlan,
            source: &[u8],
            tuple_bytes: usize,
            target: &mut [u8],
        ) -> Result<()>;
        /// Writes the grid index of each point (for arrays that cannot be gathered as bytes).
        fn write_point_ids(self: &MeshPlan, ids: &mut [i64]) -> Result<()>;
        /// Bytes of per-diamond metadata held by the hierarchy (0 for an isosurface-only one).
        fn metadata_bytes(self: &Hierarchy) -> usize;
        /// What the user should know of a tetrahedron budget (0: none) on this hierarchy: one
        /// below its coarsest mesh cannot be met (empty when there is nothing to say).
        fn budget_warning(self: &Hierarchy, max_tetrahedra: usize) -> Result<String>;
        /// Extracts the isosurfaces of `isovalues`. `samples` (of `scalar_type`) must be the very
        /// samples the hierarchy was built from: the caller keeps them alive and unchanged. `state`
        /// carries the adaptive mesh from one query to the next: reused as is when only
        /// `compute_normals` or `carrier_tetrahedra` changed, refined from the root otherwise (the
        /// measured default, `IsoStart::Root`). The surface is the same whatever `state` holds; a
        /// state last used with another hierarchy is cleared first, and a failed query clears it.
        fn isosurface(
            self: &Hierarchy,
            state: &mut IsoState,
            scalar_type: ScalarType,
            samples: &[u8],
            isovalues: &[f64],
            spec: &IsoSpec,
        ) -> Result<Box<Surface>>;

        /// Input point id (relative to the grid given to the build) of each output point.
        fn point_ids(self: &Mesh) -> &[usize];
        /// World coordinates of its points, three per point (in the order of `point_ids`).
        fn points(self: &Mesh) -> &[f64];
        /// Four point indices per tetrahedron, positively oriented (VTK_TETRA order).
        fn tets(self: &Mesh) -> &[u32];
        /// Bisection depth of each tetrahedron.
        fn depths(self: &Mesh) -> &[u8];
        /// The error of each tetrahedron's diamond: for a `query` mesh its approximation error
        /// bound, in data units; for carrier tetrahedra its isosurface error, in world units.
        fn errors(self: &Mesh) -> &[f32];
        /// Largest of `errors` (for carrier tetrahedra, the surface's `error_bound`).
        fn max_error(self: &Mesh) -> f64;
        /// Frees the tetrahedra once C++ has copied them, lowering the peak memory of large meshes;
        /// `tets()` is empty afterwards.
        fn release_tets(self: &mut Mesh);

        /// An empty isosurface state (the next query refines from the root).
        fn new_iso_state() -> Box<IsoState>;
        /// Whether the last query reused the previous adaptive mesh without refining (false
        /// before the first query and after a failed one).
        fn reused(self: &IsoState) -> bool;
        /// Forgets the adaptive mesh of the last query and the errors kept: the next query
        /// refines from the root and measures again.
        fn clear(self: &mut IsoState);

        /// World coordinates, three per point.
        fn points(self: &Surface) -> &[f64];
        /// Two input point ids (relative to the grid of the build) per point: the ends of the mesh
        /// edge it lies on, or the sample itself twice. Every point array of the input
        /// interpolates onto the surface from them.
        fn sources(self: &Surface) -> &[u32];
        /// Per point, the weight of its second source (0 at a sample).
        fn weights(self: &Surface) -> &[f64];
        /// Unit normals toward increasing values, three per point; empty unless asked for.
        fn normals(self: &Surface) -> &[f32];
        /// Three point indices per triangle, oriented so that the normal points toward increasing
        /// values.
        fn triangles(self: &Surface) -> &[u32];
        /// The isovalue of each point.
        fn values(self: &Surface) -> &[f64];
        /// Largest isosurface error (world units) of the diamonds carrying the surface.
        fn error_bound(self: &Surface) -> f64;
        /// Messages for the user (isovalues outside the data range, a triangle budget the
        /// coarsest surface exceeds), for `vtkWarningMacro`.
        fn warnings(self: &Surface) -> Result<Vec<String>>;
        /// Whether the carrier tetrahedra are there to take (asked for and not taken yet).
        fn has_carrier(self: &Surface) -> bool;
        /// For a piece's part (`isosurface_piece`): each point's id in the whole surface, the same
        /// on every rank; empty for a whole surface.
        fn global_point_ids(self: &Surface) -> &[u64];
        /// For a piece's part (`isosurface_piece`), the piece of extent `owned` of the `whole`
        /// grid: where its point data comes from (`PointSources`), the rows of its points'
        /// `sources` (two per point) first, then those of the carrier tetrahedra's points (when
        /// not taken yet, in `point_ids` order).
        fn piece_sources(
            self: &Surface,
            whole: &GridSpec,
            owned: &[i64],
        ) -> Result<Box<PointSources>>;
        /// Moves the tetrahedra carrying the surface out (their `errors`: the isosurface error of
        /// each tetrahedron's diamond, world units); an error unless `carrier_tetrahedra` was
        /// asked for, or when already taken.
        fn take_carrier(self: &mut Surface) -> Result<Box<Mesh>>;
    }

    // ---- Interval volumes (Weiss & De Floriani §2.1, §5), see `interval.rs`.
    extern "Rust" {
        /// The tetrahedra of one interval-volume query and what each point is interpolated from.
        type IntervalVolume;

        /// Extracts the interval volume of `spec` from an isosurface-only (or full) hierarchy.
        /// `samples` (of `scalar_type`) must be the very samples the hierarchy was built from.
        /// `state` is the isosurface state kept with the hierarchy (its cache serves; its mesh is
        /// forgotten); cleared first when last used with another hierarchy, and when the query
        /// fails.
        fn interval_volume(
            self: &Hierarchy,
            state: &mut IsoState,
            scalar_type: ScalarType,
            samples: &[u8],
            spec: &IntervalSpec,
        ) -> Result<Box<IntervalVolume>>;
        /// `interval_volume` on a rank that holds the whole image (this hierarchy and `samples`
        /// are the whole image's): the share of the rank at `rank` of `pieces` (every rank's
        /// extent) — the tetrahedra whose centroid its cells hold, with `global_point_ids`. Over
        /// all ranks, the serial volume, each tetrahedron once. As `isosurface_piece`, every
        /// rank calls it with the same query and `state`, and the ranks share the error
        /// measurement and the two-sided bound's check through `exchange`.
        #[allow(clippy::too_many_arguments)]
        fn interval_piece(
            self: &Hierarchy,
            state: &mut IsoState,
            scalar_type: ScalarType,
            samples: &[u8],
            spec: &IntervalSpec,
            pieces: &[i64],
            rank: usize,
            exchange: Pin<&mut PieceExchange>,
        ) -> Result<Box<IntervalVolume>>;
        /// World coordinates, three per point.
        fn points(self: &IntervalVolume) -> &[f64];
        /// Two input point ids (relative to the grid of the build) per point: the ends of the mesh
        /// edge it lies on, or the sample itself twice.
        fn sources(self: &IntervalVolume) -> &[u32];
        /// Per point, the weight of its second source (0 at a sample).
        fn weights(self: &IntervalVolume) -> &[f64];
        /// For a piece's share (`interval_piece`): each point's id in the whole volume, the same
        /// on every rank; empty for a whole volume.
        fn global_point_ids(self: &IntervalVolume) -> &[u64];
        /// For a piece's share (`interval_piece`), the piece of extent `owned` of the `whole`
        /// grid: where its point data comes from (`PointSources`), the rows of its points'
        /// `sources` (two per point).
        fn piece_sources(
            self: &IntervalVolume,
            whole: &GridSpec,
            owned: &[i64],
        ) -> Result<Box<PointSources>>;
        /// Four point indices per tetrahedron, positively oriented (VTK_TETRA order).
        fn tets(self: &IntervalVolume) -> &[u32];
        /// Bisection depth of the adaptive-mesh leaf each tetrahedron was cut from.
        fn levels(self: &IntervalVolume) -> &[u8];
        /// Leaves of the adaptive mesh that meet the range.
        fn leaves(self: &IntervalVolume) -> usize;
        /// The tolerance refined for (raised by a budget).
        fn reached_tolerance(self: &IntervalVolume) -> f64;
        /// Largest isosurface error (world units) of the diamonds carrying a bounding surface.
        fn error_bound(self: &IntervalVolume) -> f64;
        /// Messages for the user (a range missing the data, a budget that cannot be met).
        fn warnings(self: &IntervalVolume) -> Result<Vec<String>>;
    }

    // ---- Isodiamond hierarchies (Weiss & De Floriani §5–§7), see `isodiamonds.rs`.
    extern "Rust" {
        /// A relevant (RI) or minimal (MI) isodiamond hierarchy of one isosurface or one interval
        /// volume: extracted at any rung of its ladder of tolerances without the samples.
        type Isodiamonds;

        /// Builds the RI (`minimal` false) or MI hierarchy of the isosurface `levels[0]` (one
        /// level) or of the interval volume `[levels[0], levels[1]]` (two) from this hierarchy and
        /// `samples` (of `scalar_type`), the very samples it was built from. Its ladder is the
        /// default one: 4 % down to 1/16 % of the image diagonal, halving, then 0. With progress
        /// (one step per rung) and abort.
        fn build_isodiamonds(
            self: &Hierarchy,
            scalar_type: ScalarType,
            samples: &[u8],
            levels: &[f64],
            minimal: bool,
            progress: Pin<&mut ProgressObserver>,
        ) -> Result<Box<Isodiamonds>>;
        /// Fails with the reason when an isodiamond hierarchy's extraction would refuse a region
        /// of interest or carrier tetrahedra: asked before building one.
        fn check_isodiamond_query(region_of_interest: bool, carrier_tetrahedra: bool)
            -> Result<()>;
        /// The isosurface of `spec` (`isovalues`: this hierarchy's one isovalue) at the finest rung
        /// whose tolerance is at most `spec.tolerance`, raised to the finest that fits a triangle
        /// budget; normals of the surface itself. Refuses a region of interest and carrier
        /// tetrahedra.
        fn isosurface(
            self: &Isodiamonds,
            isovalues: &[f64],
            spec: &IsoSpec,
        ) -> Result<Box<Surface>>;
        /// The interval volume of `spec` (its range: this hierarchy's) as `isosurface` picks the
        /// rung, its sources and weights from the stored crossings. Refuses a region of interest.
        fn interval_volume(self: &Isodiamonds, spec: &IntervalSpec) -> Result<Box<IntervalVolume>>;
        /// Bytes the hierarchy holds in memory.
        fn memory_bytes(self: &Isodiamonds) -> usize;
        /// The rung tolerances, world units, decreasing, the last 0.
        fn ladder(self: &Isodiamonds) -> &[f64];
        /// Bytes an isosurface state holds between queries (caches and the kept adaptive mesh).
        fn memory_bytes(self: &IsoState) -> usize;
    }

    // ---- Material interfaces (Gregorski §5), see `material.rs`.
    extern "Rust" {
        /// Collects the input of a material model (copies of the arrays).
        type MaterialBuilder;
        /// The prepared input (materials, interface meshes, spatial index), kept between queries.
        type MaterialModel;
        /// The adaptive mesh of one material query with its per-vertex and per-tetrahedron arrays.
        type MaterialMesh;
        /// Labelled polygons: the approximated interfaces or a plane cut, with their arrays.
        type PolygonMesh;
        /// The named arrays of one output.
        type OutputArrays;

        /// The arrays to read: the selected volume-fraction arrays (none: every single-component
        /// array named like a fraction), fields and per-material field arrays ("<field> for
        /// <material>" or "<field> (<material>)"; a <field> that is none of `fields` is added
        /// after them, computed from its per-material arrays). An error when fewer than 2
        /// fractions are found, an array is selected twice, a per-material array matches no field
        /// and material, or an array to read is missing or has more than one component.
        fn select_material_arrays(
            input: &[InputArrayInfo],
            fractions: &[String],
            fields: &[String],
            material_fields: &[String],
        ) -> Result<ArraySelection>;
        /// A builder on `grid` (refused when an axis has fewer than 2 points).
        fn new_material_builder(grid: &GridSpec) -> Result<Box<MaterialBuilder>>;
        /// The uniform grid of a rectilinear grid's coordinates; an error when an axis is not
        /// uniformly spaced.
        fn grid_from_coordinates(x: &[f64], y: &[f64], z: &[f64]) -> Result<GridSpec>;
        /// Adds the point volume fraction of the next material (copied).
        fn add_fraction(self: &mut MaterialBuilder, values: &[f32]) -> Result<()>;
        /// Adds the next point field to approximate (copied), named `name` in messages.
        fn add_field(self: &mut MaterialBuilder, name: &str, values: &[f32]) -> Result<()>;
        /// Adds the next field, `name`, as one given only per material: its mixed values are the
        /// fraction-weighted sum of its per-material arrays (materials without one count 0).
        fn add_field_from_materials(self: &mut MaterialBuilder, name: &str) -> Result<()>;
        /// Adds the point values (copied) of field `field` (the order of `add_field` and
        /// `add_field_from_materials`) inside material `material` (the order of `add_fraction`),
        /// read at the samples of that material only.
        fn add_material_field(
            self: &mut MaterialBuilder,
            field: usize,
            material: usize,
            values: &[f32],
        ) -> Result<()>;
        /// Sets the user's interface meshes from a triangle soup: points (3 each), triangles (3
        /// point indices each), 2 materials per triangle (the normal points from the first into the
        /// second) and normals (none, 3 per triangle, or 3 per point with `point_normals`).
        fn set_interfaces(
            self: &mut MaterialBuilder,
            points: &[f64],
            triangles: &[u32],
            pairs: &[i64],
            normals: &[f64],
            point_normals: bool,
        ) -> Result<()>;
        /// Validates the input and prepares the model.
        fn build(self: &MaterialBuilder) -> Result<Box<MaterialModel>>;

        /// Refines to `query`: interfaces first, then fields.
        fn refine(
            self: &MaterialModel,
            query: &MaterialQuerySpec,
            progress: Pin<&mut ProgressObserver>,
        ) -> Result<Box<MaterialMesh>>;

        /// World coordinates, three per vertex.
        fn points(self: &MaterialMesh) -> &[f64];
        /// Four vertex indices per tetrahedron, positively oriented (VTK_TETRA order).
        fn tets(self: &MaterialMesh) -> &[u32];
        /// Largest interface error (world units) and field error (data units) over the mesh.
        fn max_interface_error(self: &MaterialMesh) -> f64;
        fn max_field_error(self: &MaterialMesh) -> f64;
        /// What to tell the user when the mesh misses a tolerance of `query` (the interface
        /// error's, where the next finer lattice would not fit), empty when it meets both.
        fn tolerance_warning(self: &MaterialMesh, query: &MaterialQuerySpec) -> String;
        /// The name of each interface, "<a>|<b>" with the names `materials`.
        fn interface_names(self: &MaterialMesh, materials: &[String]) -> Vec<String>;
        /// The named arrays of the tetrahedra, for materials and fields named `materials` and
        /// `fields` and the query as the user gave it (written as field data).
        fn tetrahedra_arrays(
            self: &MaterialMesh,
            materials: &[String],
            fields: &[String],
            query: &MaterialQuerySpec,
        ) -> Result<Box<OutputArrays>>;
        /// The approximated interfaces (crack-free across tetrahedra) and their arrays.
        fn interface_polygons(self: &MaterialMesh) -> Result<Box<PolygonMesh>>;
        /// The cut by `plane` and its arrays: the material of each polygon, each field (named by
        /// `fields`) of the polygon's material at each point.
        fn slice(
            self: &MaterialMesh,
            plane: &PlaneSpec,
            fields: &[String],
        ) -> Result<Box<PolygonMesh>>;
        /// Under MPI, on a rank that computed the whole mesh: the share the rank at `rank` of
        /// `pieces` (every rank's extent relative to the whole grid `grid`) owns — the cells
        /// whose centroid its half-open cell box holds (the whole grid's far faces included) —
        /// with `global_point_ids`, each point's index in the whole output. Over all ranks, the
        /// whole output, each cell once. The tetrahedra:
        fn piece(
            self: &MaterialMesh,
            grid: &GridSpec,
            pieces: &[i64],
            rank: usize,
        ) -> Result<Box<MaterialMesh>>;
        /// The interfaces' share, and the cut's:
        fn interface_polygons_piece(
            self: &MaterialMesh,
            grid: &GridSpec,
            pieces: &[i64],
            rank: usize,
        ) -> Result<Box<PolygonMesh>>;
        fn slice_piece(
            self: &MaterialMesh,
            plane: &PlaneSpec,
            fields: &[String],
            grid: &GridSpec,
            pieces: &[i64],
            rank: usize,
        ) -> Result<Box<PolygonMesh>>;
        /// A share's point ids in the whole output (empty for a whole output).
        fn global_point_ids(self: &MaterialMesh) -> &[u64];

        /// World coordinates, three per point.
        fn points(self: &PolygonMesh) -> &[f64];
        /// One offset per polygon plus one into `connectivity()` (empty without polygons).
        fn offsets(self: &PolygonMesh) -> &[u32];
        fn connectivity(self: &PolygonMesh) -> &[u32];
        fn arrays(self: &PolygonMesh) -> &OutputArrays;
        fn global_point_ids(self: &PolygonMesh) -> &[u64];

        fn len(self: &OutputArrays) -> usize;
        /// What array `i` is (an error past the last).
        fn info(self: &OutputArrays, i: usize) -> Result<OutputArrayInfo>;
        /// The values of array `i`, as the bytes of its `value_type` values (tuples × components
        /// of them), in place (an error past the last).
        fn bytes(self: &OutputArrays, i: usize) -> Result<&[u8]>;

        /// A progressive tetrahedral mesh (base mesh + vertex splits, Labsik et al.) and its current
        /// level, kept by `vtkProgressiveTetrahedralMesh` between executions.
        type Progressive;
        /// Prepares the simplification of the tetrahedra (`tets`: 4 point indices each, positively
        /// oriented) of `points` (3 coordinates each), the field error measured on `scalars` (one
        /// per point); no collapse is made yet (`reduce_for`), the current level is the original.
        /// For a piece of a distributed mesh, `boundary` is its boundary points and `seam_with`
        /// the boundary points the other pieces sent it (`progressive_seam_messages`; both empty
        /// when serial): the piece's boundary points at those positions are never removed, so the
        /// pieces stay conforming.
        fn build_progressive(
            points: &[f64],
            tets: &[i64],
            scalars: &[f64],
            spec: &ProgressiveSpec,
            boundary: &[u32],
            seam_with: &[f64],
        ) -> Result<Box<Progressive>>;
        /// What the piece `rank` of a distributed mesh (tetrahedra `tets`, 4 indices into
        /// `points` each) sends the other pieces, whose bounds are `boxes` (6 values per rank, VTK
        /// order; an empty piece's minima above its maxima): its boundary points inside each.
        fn progressive_seam_messages(
            points: &[f64],
            tets: &[i64],
            boxes: &[f64],
            rank: usize,
        ) -> Result<SeamMessages>;
        /// Continues the collapse sequence, if it has not gone that far, until its base mesh has
        /// at most `(1 - target_reduction)` of the original's tetrahedra or no collapse is left,
        /// with progress and abort (the collapses made until an abort are kept); the levels already
        /// made keep their meshes (numbered higher) and the current level its mesh. Returns how
        /// many collapses it added (0: it had gone that far).
        fn reduce_for(
            self: &mut Progressive,
            target_reduction: f64,
            progress: Pin<&mut ProgressObserver>,
        ) -> Result<usize>;
        /// What the user should know after `reduce_for(target_reduction)`: that the reduction
        /// stopped short of it, where and why (empty when it did not).
        fn reduction_warning(self: &Progressive, target_reduction: f64) -> Result<String>;
        /// The number of vertex splits: levels go from 0 (the base mesh) to it (the original).
        fn number_of_levels(self: &Progressive) -> usize;
        /// The coarsest level with at most `(1 - target_reduction)` of the original's tetrahedra
        /// whose maximum field error, and every finer level's, is at most `max_field_error` (0 = no
        /// limit).
        fn level_for(
            self: &Progressive,
            target_reduction: f64,
            max_field_error: f64,
        ) -> Result<usize>;
        /// Moves to `level` by replaying vertex splits or collapses (no recomputation) and extracts
        /// it; returns how many were replayed.
        fn set_level(self: &mut Progressive, level: usize) -> Result<usize>;
        /// The current level.
        fn current_level(self: &Progressive) -> usize;
        /// The original point index of each point of the current level.
        fn level_point_ids(self: &Progressive) -> &[u32];
        /// Copies the tuple of each point of the current level from `source` (`tuple_bytes` bytes
        /// per input point) into `target` (one tuple per point of `level_point_ids`), in parallel:
        /// a point array of standard memory layout passed through.
        fn gather_level_point_values(
            self: &Progressive,
            source: &[u8],
            tuple_bytes: usize,
            target: &mut [u8],
        ) -> Result<()>;
        /// The number of tetrahedra of the current level.
        fn level_tet_count(self: &Progressive) -> usize;
        /// Writes the current level into the caller's arrays, in parallel: the coordinates of its
        /// points (3 per point of `level_point_ids`), four indices into `level_point_ids` per
        /// tetrahedron, the field error of each tetrahedron. Fails on arrays of other lengths.
        fn fill_level(
            self: &Progressive,
            coordinates: &mut [f64],
            connectivity: &mut [u32],
            field_errors: &mut [f64],
        ) -> Result<()>;
        /// The current level's maximum and RMS field error over the removed original vertices.
        fn level_max_field_error(self: &Progressive) -> f64;
        fn level_rms_field_error(self: &Progressive) -> f64;
        /// How many coincident input points were merged, and how many tetrahedra that flattened.
        fn merged_points(self: &Progressive) -> usize;
        fn dropped_tets(self: &Progressive) -> usize;
        /// Extracts the isosurfaces of `isovalues` (none: no surface) on the current level, kept up
        /// to date under every later `set_level` by the tetrahedra of each split only (Labsik §4.3);
        /// new isovalues find their tetrahedra in the interval tree (§4.2).
        fn set_isovalues(self: &mut Progressive, isovalues: &[f64]) -> Result<()>;
        /// The isosurface of the current level: 3 coordinates per point, the isovalue of each point,
        /// 3 point indices per triangle (oriented toward increasing values).
        fn iso_points(self: &Progressive) -> &[f64];
        fn iso_values(self: &Progressive) -> &[f64];
        fn iso_triangles(self: &Progressive) -> &[u32];
    }

    // ---- View-dependent meshes and their visibility order (Gregorski §4, Marchesin §6), see
    // `view.rs`.
    extern "Rust" {
        /// The split and merge queues' state and the view-error bounds of one hierarchy, kept
        /// between executions.
        type ViewMesh;
        /// The BSP tree of cells rebuilt from their bisection paths.
        type PathOrder;

        /// The base mesh's state and the view-error bounds (2 bytes per point) of `hierarchy`.
        fn new_view_mesh(hierarchy: &Hierarchy) -> Result<Box<ViewMesh>>;
        /// Whether the state belongs to `hierarchy`.
        fn belongs_to(self: &ViewMesh, hierarchy: &Hierarchy) -> bool;
        /// Splits and merges from the current mesh to the mesh of `spec`'s view; unchanged on error.
        fn update_view(
            self: &mut ViewMesh,
            hierarchy: &Hierarchy,
            spec: &ViewSpec,
        ) -> Result<ViewFrame>;
        /// The current mesh, counted, written with `write_tets_*` like a query's.
        fn view_plan(self: &ViewMesh, hierarchy: &Hierarchy) -> Result<Box<MeshPlan>>;
        /// The grid the hierarchy was built for.
        fn grid_spec(self: &Hierarchy) -> GridSpec;
        /// Has `plan` write its tetrahedra in exact visibility order from `eye` (3 coordinates):
        /// `sort` 1 back to front, 2 front to back, 0 as planned (ascending bisection paths).
        fn order_plan(self: &Hierarchy, plan: &mut MeshPlan, sort: u8, eye: &[f64]) -> Result<()>;
        /// Writes each tetrahedron's bisection path into `paths` (one per tetrahedron of the plan,
        /// in the order they are written).
        fn write_paths(self: &MeshPlan, paths: &mut [u64]) -> Result<()>;
        /// The tree of cells whose bisection paths are `paths`, refined on `grid`.
        fn new_path_order(grid: &GridSpec, paths: &[u64]) -> Result<Box<PathOrder>>;
        fn number_of_cells(self: &PathOrder) -> usize;
        /// Writes the cell ids in visibility order from `eye` (3 coordinates) into `cells`.
        fn order_cells(
            self: &PathOrder,
            eye: &[f64],
            front_to_back: bool,
            cells: &mut [i64],
        ) -> Result<()>;
    }
}

pub use ffi::{
    ArrayAssociation, ArraySelection, ArrayType, GridSpec, InputArrayInfo, IntervalSpec, IsoSpec,
    MaterialQuerySpec, OutputArrayInfo, PlaneSpec, PointFrame, ProgressiveSpec, QuerySpec,
    ScalarType, ViewFrame, ViewSpec,
};

pub mod progressive;
pub use progressive::{build_progressive, progressive_seam_messages, Progressive};

pub mod interval;
pub use interval::IntervalVolume;

pub mod isodiamonds;
pub use isodiamonds::{check_isodiamond_query, Isodiamonds};

pub mod material;
pub mod piece;
pub use material::{
    grid_from_coordinates, new_material_builder, select_material_arrays, MaterialBuilder,
    MaterialMesh, MaterialModel, OutputArrays, PolygonMesh,
};
pub mod view;
pub use piece::{
    build_piece_hierarchy, piece_box_local_ids, piece_check_cover, piece_local_ids,
    piece_point_owners, piece_requests, PieceHierarchy, PieceRefinement, PointSources,
};
pub use view::{new_path_order, new_view_mesh, PathOrder, ViewMesh};

/// Opaque handle on a [`diamonds::Hierarchy`] for C++, with an identity that tells the
/// [`IsoState`]s of different hierarchies apart.
pub struct Hierarchy {
    hierarchy: diamonds::Hierarchy,
    id: u64,
}

/// Opaque handle on a [`diamonds::IsoState`] for C++: the split set of the last
/// isosurface query, and the identity of the [`Hierarchy`] it was refined on. A split set belongs
/// to one hierarchy (a rebuilt one may have the same lattice but other samples): a query on another
/// hierarchy clears the state first, so a stale mesh can never be reused.
#[derive(Default)]
pub struct IsoState {
    state: diamonds::IsoState,
    hierarchy: Option<u64>,
}

/// Opaque handle on a [`TetMesh`] for C++, checked for consistency before it is handed over.
pub struct Mesh(TetMesh);

/// Opaque handle on a [`diamonds::mesh::MeshPlan`] for C++, with the identity of the [`Hierarchy`]
/// that planned it (its errors are that hierarchy's).
pub struct MeshPlan {
    plan: diamonds::mesh::MeshPlan,
    hierarchy: u64,
}

/// Opaque handle on a [`diamonds::IsoSurface`] for C++, checked for consistency before it is handed
/// over. The carrier mesh is moved out of the surface into a [`Mesh`] so that C++ reads it through
/// the same accessors as a query's mesh.
pub struct Surface {
    surface: IsoSurface,
    carrier: Option<Box<Mesh>>,
}

/// Runs `body`, turning a panic into an error message instead of letting it unwind into C++.
///
/// `AssertUnwindSafe` is sound here: a panic can only leave the core's own local state broken,
/// and that state is dropped during the unwind. What survives a panic is borrowed immutably
/// (`&Hierarchy`, `&Mesh`, the sample bytes), is the C++ progress observer, which holds no
/// invariant the Rust side could break, or is an [`IsoState`], which [`Hierarchy::isosurface`]
/// clears when its body fails or panics.
///
/// Memory: the outermost `guard` of a call arms the emergency reserve of [`ALLOCATOR`]
/// ([`diamonds::memory::arm`]); when an allocation failed during the call (the reserve given
/// back to let it finish or reach a progress report, where [`reporter`] stops it), its result is
/// dropped and the call fails with an out-of-memory message instead of aborting the process.
pub fn guard<T>(what: &str, body: impl FnOnce() -> Result<T, String>) -> Result<T, String> {
    let outermost = GUARD_DEPTH.with(|depth| {
        depth.set(depth.get() + 1);
        depth.get() == 1
    });
    if outermost {
        diamonds::memory::arm();
    }
    let result = catch_unwind(AssertUnwindSafe(body)).unwrap_or_else(|payload| {
        Err(format!(
            "internal error in the Diamonds core while {what}: {}. Please report this with the input that caused it.",
            panic_message(payload.as_ref())
        ))
    });
    GUARD_DEPTH.with(|depth| depth.set(depth.get() - 1));
    if outermost {
        RAN_OUT_OF_MEMORY.with(|short| short.set(diamonds::memory::ran_short()));
    }
    if outermost && diamonds::memory::exhausted() {
        drop(result);
        return Err(format!(
            "out of memory while {what}: an allocation failed, so the work was stopped and its memory \
             freed. Raise the tolerance, set a maximum number of cells, restrict the input (e.g. \
             Extract Subset) or free memory, and apply again."
        ));
    }
    result
}

thread_local! {
    /// Nesting depth of [`guard`] on this thread (bridge functions may call each other).
    static GUARD_DEPTH: std::cell::Cell<u32> = const { std::cell::Cell::new(0) };
    /// Whether memory ran short during the last outermost [`guard`] on this thread.
    static RAN_OUT_OF_MEMORY: std::cell::Cell<bool> = const { std::cell::Cell::new(false) };
}

/// Whether memory ran short during the last bridge call on this thread
/// ([`diamonds::memory::ran_short`]): when that call failed, it may succeed once memory is free,
/// so a filter does not remember the failure as it remembers one of its input.
pub fn ran_out_of_memory() -> bool {
    RAN_OUT_OF_MEMORY.with(|short| short.get())
}

/// The global allocator of the plugin's Rust code: the system's, with an emergency reserve, so
/// that running out of memory ends the call with an error (see [`guard`]) instead of aborting
/// ParaView.
#[global_allocator]
static ALLOCATOR: diamonds::memory::Reserving = diamonds::memory::Reserving;

/// The C++ observer's `report` as the core's progress callback: stops the work (returns false,
/// as an abort request does) once an allocation has failed, so that [`guard`] can report it.
fn reporter(mut progress: Pin<&mut ffi::ProgressObserver>) -> impl FnMut(f64) -> bool + '_ {
    move |fraction| !diamonds::memory::exhausted() && progress.as_mut().report(fraction)
}

/// The text of a panic payload (`panic!` carries a `&str` or a `String`).
fn panic_message(payload: &(dyn Any + Send)) -> &str {
    if let Some(s) = payload.downcast_ref::<&str>() {
        s
    } else if let Some(s) = payload.downcast_ref::<String>() {
        s
    } else {
        "(no message)"
    }
}

/// Reinterprets `bytes` as a slice of `scalar_type` values, in place.
///
/// Fails (instead of copying) when the buffer is misaligned for the type or its length is not a
/// multiple of the value size; VTK's arrays are malloc-aligned, so neither happens in practice.
pub fn typed_slice(scalar_type: ScalarType, bytes: &[u8]) -> Result<ScalarSlice<'_>, String> {
    fn cast<T: bytemuck::Pod>(bytes: &[u8]) -> Result<&[T], String> {
        if bytes.is_empty() {
            return Ok(&[]); // C++ may hand over an empty slice at any address
        }
        bytemuck::try_cast_slice(bytes).map_err(|e| {
            format!(
                "the sample buffer ({} bytes at {:p}) cannot be read as {}: {e:?}",
                bytes.len(),
                bytes.as_ptr(),
                std::any::type_name::<T>()
            )
        })
    }
    Ok(match scalar_type {
        ScalarType::U8 => ScalarSlice::U8(cast(bytes)?),
        ScalarType::I8 => ScalarSlice::I8(cast(bytes)?),
        ScalarType::U16 => ScalarSlice::U16(cast(bytes)?),
        ScalarType::I16 => ScalarSlice::I16(cast(bytes)?),
        ScalarType::U32 => ScalarSlice::U32(cast(bytes)?),
        ScalarType::I32 => ScalarSlice::I32(cast(bytes)?),
        ScalarType::F32 => ScalarSlice::F32(cast(bytes)?),
        ScalarType::F64 => ScalarSlice::F64(cast(bytes)?),
        other => return Err(format!("unknown scalar type code {}", other.repr)),
    })
}

/// Builds the hierarchy with a Rust progress callback; [`build_hierarchy`] is this plus the
/// C++ observer. Not itself guarded: callers go through [`guard`].
pub fn build_with(
    grid: &GridSpec,
    scalar_type: ScalarType,
    samples: &[u8],
    progress: &mut dyn FnMut(f64) -> bool,
) -> Result<Hierarchy, String> {
    let scalars = typed_slice(scalar_type, samples)?;
    wrap(diamonds::Hierarchy::build(
        core_grid(grid),
        scalars,
        progress,
    ))
}

/// Builds the isosurface-only hierarchy ([`diamonds::Hierarchy::build_for_isosurfaces`]). Not itself
/// guarded: callers go through [`guard`].
pub fn build_isosurfaces_with(
    grid: &GridSpec,
    scalar_type: ScalarType,
    samples: &[u8],
) -> Result<Hierarchy, String> {
    let scalars = typed_slice(scalar_type, samples)?;
    wrap(diamonds::Hierarchy::build_for_isosurfaces(
        core_grid(grid),
        scalars,
    ))
}

/// The core's query for `query`.
fn core_query(query: &QuerySpec) -> Query {
    Query {
        tolerance: query.tolerance,
        max_tetrahedra: query.max_tetrahedra,
        region_of_interest: query
            .use_region_of_interest
            .then_some(query.region_of_interest),
    }
}

fn core_grid(grid: &GridSpec) -> Grid {
    Grid {
        dims: grid.dims,
        origin: grid.origin,
        spacing: grid.spacing,
    }
}

/// A new identity for a hierarchy (see [`Hierarchy`]) or a piece of one ([`PieceHierarchy`]): the
/// mesh plans they make carry it.
pub(crate) fn next_id() -> u64 {
    static NEXT_ID: AtomicU64 = AtomicU64::new(0);
    NEXT_ID.fetch_add(1, Ordering::Relaxed)
}

/// Gives a built hierarchy its id (see [`Hierarchy`]).
fn wrap(built: diamonds::Result<diamonds::Hierarchy>) -> Result<Hierarchy, String> {
    built
        .map(|hierarchy| Hierarchy {
            hierarchy,
            id: next_id(),
        })
        .map_err(|e| e.to_string())
}

fn new_iso_state() -> Box<IsoState> {
    Box::default()
}

impl ffi::IsoSpec {
    /// The core's query for `isovalues`.
    fn query(&self, isovalues: &[f64]) -> IsoQuery {
        IsoQuery {
            isovalues: isovalues.to_vec(),
            tolerance: self.tolerance,
            max_triangles: self.max_triangles,
            region_of_interest: self
                .use_region_of_interest
                .then_some(self.region_of_interest),
            compute_normals: self.compute_normals,
            carrier_tetrahedra: self.carrier_tetrahedra,
        }
    }
}

impl ffi::IntervalSpec {
    /// The core's query.
    fn query(&self) -> diamonds::interval::IntervalQuery {
        diamonds::interval::IntervalQuery {
            range: self.range,
            tolerance: self.tolerance,
            max_tetrahedra: self.max_tetrahedra,
            region_of_interest: self
                .use_region_of_interest
                .then_some(self.region_of_interest),
        }
    }
}

impl IsoState {
    /// Whether the last query reused the previous split set without refining.
    pub fn reused(&self) -> bool {
        self.state.last().is_some_and(|stats| stats.reused)
    }

    /// See [`diamonds::IsoState::clear`].
    pub fn clear(&mut self) {
        self.state.clear();
    }
}

fn build_isosurface_hierarchy(
    grid: &GridSpec,
    scalar_type: ScalarType,
    samples: &[u8],
) -> Result<Box<Hierarchy>, String> {
    guard("building the diamond hierarchy", || {
        build_isosurfaces_with(grid, scalar_type, samples).map(Box::new)
    })
}

fn build_hierarchy(
    grid: &GridSpec,
    scalar_type: ScalarType,
    samples: &[u8],
    mut progress: Pin<&mut ffi::ProgressObserver>,
) -> Result<Box<Hierarchy>, String> {
    guard("building the diamond hierarchy", || {
        let mut report = reporter(progress.as_mut());
        build_with(grid, scalar_type, samples, &mut report).map(Box::new)
    })
}

impl Hierarchy {
    /// Refines for `query` and counts the mesh ([`diamonds::Hierarchy::plan`]).
    pub fn plan_mesh(&self, query: &QuerySpec) -> Result<Box<MeshPlan>, String> {
        guard("refining the adaptive mesh", || {
            let plan = self
                .hierarchy
                .plan(&core_query(query))
                .map_err(|e| e.to_string())?;
            Ok(Box::new(MeshPlan {
                plan,
                hierarchy: self.id,
            }))
        })
    }

    /// Writes the tetrahedra of `plan` into the caller's arrays ([`diamonds::Hierarchy::write_tets`]).
    pub fn write_tets<I: diamonds::mesh::Index>(
        &self,
        plan: &MeshPlan,
        connectivity: &mut [I],
        offsets: &mut [I],
        depths: &mut [u8],
        errors: &mut [f32],
    ) -> Result<f64, String> {
        plan.written_by(self.id, |p| {
            self.hierarchy
                .write_tets(p, connectivity, offsets, depths, errors)
        })
    }

    fn write_tets_i32(
        &self,
        plan: &MeshPlan,
        connectivity: &mut [i32],
        offsets: &mut [i32],
        depths: &mut [u8],
        errors: &mut [f32],
    ) -> Result<f64, String> {
        self.write_tets(plan, connectivity, offsets, depths, errors)
    }

    fn write_tets_i64(
        &self,
        plan: &MeshPlan,
        connectivity: &mut [i64],
        offsets: &mut [i64],
        depths: &mut [u8],
        errors: &mut [f32],
    ) -> Result<f64, String> {
        self.write_tets(plan, connectivity, offsets, depths, errors)
    }

    fn metadata_bytes(&self) -> usize {
        self.hierarchy.metadata_bytes()
    }

    fn budget_warning(&self, max_tetrahedra: usize) -> Result<String, String> {
        guard("checking the tetrahedron budget", || {
            Ok(self
                .hierarchy
                .budget_warning(max_tetrahedra)
                .unwrap_or_default())
        })
    }

    /// Extracts the isosurfaces of `isovalues` and checks the result before C++ indexes with it.
    /// `samples` must be the samples the hierarchy was built from. `state` keeps the adaptive mesh
    /// between queries ([`diamonds::IsoState::extract`]); it is cleared first when it was
    /// last used with another hierarchy, and cleared when the query fails.
    pub fn isosurface(
        &self,
        state: &mut IsoState,
        scalar_type: ScalarType,
        samples: &[u8],
        isovalues: &[f64],
        spec: &IsoSpec,
    ) -> Result<Box<Surface>, String> {
        self.isosurface_of(state, scalar_type, samples, isovalues, spec, None)
    }

    /// [`Hierarchy::isosurface`], or with `piece` (every piece's point box and this piece's
    /// position) the part of it that piece owns ([`diamonds::IsoState::extract_shared`], sharing the bound's check through the exchange).
    pub(crate) fn isosurface_of(
        &self,
        state: &mut IsoState,
        scalar_type: ScalarType,
        samples: &[u8],
        isovalues: &[f64],
        spec: &IsoSpec,
        piece: Option<(&[PointBox], usize, &dyn diamonds::isosurface::Exchange)>,
    ) -> Result<Box<Surface>, String> {
        let what = "extracting the isosurface";
        self.with_iso_state(
            state,
            what,
            scalar_type,
            samples,
            |state, scalars, expected| {
                let query = spec.query(isovalues);
                let mut surface = match piece {
                    None => state.extract(&self.hierarchy, scalars, &query),
                    Some((pieces, me, exchange)) => {
                        diamonds::hierarchy::piece::CellOwner::new(pieces, me).and_then(|owner| {
                            let partition = diamonds::isosurface::Partition::new(owner, exchange);
                            state.extract_shared(&self.hierarchy, scalars, &query, &partition)
                        })
                    }
                }
                .map_err(|e| e.to_string())?;
                check_core(check_isosurface_arrays(
                    &surface,
                    &query,
                    self.hierarchy.grid().len(),
                ))?;
                let carrier = surface.carrier.take();
                if let Some(mesh) = &carrier {
                    check_core(check_mesh_arrays(mesh, expected))?;
                }
                Ok(Box::new(Surface {
                    surface,
                    carrier: carrier.map(|mesh| Box::new(Mesh(mesh))),
                }))
            },
        )
    }

    /// Runs a query `body` (inside [`guard`], for `what`) on `state` with the samples the hierarchy
    /// was built from and their number: `state` is cleared first when it was last used with another
    /// hierarchy, and cleared when the query fails; samples of another length are refused.
    pub(crate) fn with_iso_state<R>(
        &self,
        state: &mut IsoState,
        what: &str,
        scalar_type: ScalarType,
        samples: &[u8],
        body: impl FnOnce(&mut diamonds::IsoState, ScalarSlice<'_>, usize) -> Result<R, String>,
    ) -> Result<R, String> {
        if state.hierarchy != Some(self.id) {
            state.state.clear();
            state.hierarchy = Some(self.id);
        }
        let result = guard(what, || {
            let scalars = typed_slice(scalar_type, samples)?;
            let expected = self.hierarchy.grid().len();
            if scalars.len() != expected {
                return Err(format!(
                    "the sample array has {} values but the hierarchy was built for {expected} points",
                    scalars.len()
                ));
            }
            body(&mut state.state, scalars, expected)
        });
        if result.is_err() {
            state.state.clear();
        }
        result
    }
}

/// Runs one of the core's array checks (`diamonds::validate::check_*_arrays`) on a result before C++
/// indexes with it: a violation is a core bug, reported as an error instead of becoming an
/// out-of-bounds write in C++.
pub(crate) fn check_core(outcome: Result<(), String>) -> Result<(), String> {
    outcome.map_err(|e| format!("internal error in the Diamonds core: {e}"))
}

impl MeshPlan {
    fn number_of_tetrahedra(&self) -> usize {
        self.plan.tets()
    }

    fn number_of_points(&self) -> usize {
        self.plan.points()
    }

    /// Writes the points at `frame`'s positions ([`diamonds::mesh::MeshPlan::write_points`]).
    pub fn write_points(&self, frame: &PointFrame, xyz: &mut [f64]) -> Result<(), String> {
        guard("writing the mesh's points", || {
            let [nx, ny, _] = self.plan.grid_dims();
            // vtkImageData's formula for its bounds, in its order of operations.
            let position = |i: usize| {
                let ijk = [i % nx, i / nx % ny, i / (nx * ny)];
                std::array::from_fn(|a| {
                    frame.origin[a]
                        + (frame.first_index[a] as f64 + ijk[a] as f64) * frame.spacing[a]
                })
            };
            self.plan
                .write_points(position, xyz)
                .map_err(|e| e.to_string())
        })
    }

    /// Copies a point array through ([`diamonds::mesh::MeshPlan::gather`]).
    pub fn gather_point_values(
        &self,
        source: &[u8],
        tuple_bytes: usize,
        target: &mut [u8],
    ) -> Result<(), String> {
        guard("passing a point array through", || {
            self.plan
                .gather(source, tuple_bytes, target)
                .map_err(|e| e.to_string())
        })
    }

    /// Writes the grid index of each point ([`diamonds::mesh::MeshPlan::write_point_ids`]).
    pub fn write_point_ids(&self, ids: &mut [i64]) -> Result<(), String> {
        guard("writing the mesh's point ids", || {
            self.plan.write_point_ids(ids).map_err(|e| e.to_string())
        })
    }

    /// The points of a piece's plan its piece does not hold
    /// ([`diamonds::mesh::MeshPlan::remote_point_ids`]).
    pub fn piece_remote_point_ids(&self) -> Result<Vec<u64>, String> {
        guard("finding the points other pieces hold", || {
            self.plan.remote_point_ids().map_err(|e| e.to_string())
        })
    }

    /// Copies a point array through on a piece ([`diamonds::mesh::MeshPlan::gather_piece`]).
    pub fn gather_piece_point_values(
        &self,
        local: &[u8],
        fetched: &[u8],
        tuple_bytes: usize,
        target: &mut [u8],
    ) -> Result<(), String> {
        guard("passing a point array through", || {
            self.plan
                .gather_piece(local, fetched, tuple_bytes, target)
                .map_err(|e| e.to_string())
        })
    }

    /// Runs `write` (the tetrahedra's writer of the hierarchy of identity `id`) on the plan, which
    /// that hierarchy must have made: another's plan is an error, not a mesh written with the
    /// wrong errors.
    pub(crate) fn written_by(
        &self,
        id: u64,
        write: impl FnOnce(&diamonds::mesh::MeshPlan) -> diamonds::Result<f64>,
    ) -> Result<f64, String> {
        guard("writing the adaptive mesh", || {
            if self.hierarchy != id {
                return Err("the mesh plan belongs to another hierarchy".into());
            }
            write(&self.plan).map_err(|e| e.to_string())
        })
    }

    /// The plan as the core returned it.
    pub fn inner(&self) -> &diamonds::mesh::MeshPlan {
        &self.plan
    }
}

impl Mesh {
    fn points(&self) -> &[f64] {
        self.0.points.as_flattened()
    }

    fn point_ids(&self) -> &[usize] {
        &self.0.point_ids
    }

    fn tets(&self) -> &[u32] {
        self.0.tets.as_flattened()
    }

    fn depths(&self) -> &[u8] {
        &self.0.depths
    }

    fn errors(&self) -> &[f32] {
        &self.0.errors
    }

    fn release_tets(&mut self) {
        self.0.tets = Vec::new();
    }

    fn max_error(&self) -> f64 {
        self.0.max_error
    }

    /// The mesh as the core returned it.
    pub fn inner(&self) -> &TetMesh {
        &self.0
    }
}

impl Surface {
    fn points(&self) -> &[f64] {
        self.surface.points.as_flattened()
    }

    fn sources(&self) -> &[u32] {
        self.surface.sources.as_flattened()
    }

    fn weights(&self) -> &[f64] {
        &self.surface.weights
    }

    fn normals(&self) -> &[f32] {
        self.surface.normals.as_flattened()
    }

    fn triangles(&self) -> &[u32] {
        self.surface.triangles.as_flattened()
    }

    fn values(&self) -> &[f64] {
        &self.surface.values
    }

    fn error_bound(&self) -> f64 {
        self.surface.error_bound
    }

    fn has_carrier(&self) -> bool {
        self.carrier.is_some()
    }

    fn global_point_ids(&self) -> &[u64] {
        &self.surface.point_ids
    }

    fn warnings(&self) -> Result<Vec<String>, String> {
        guard("reading the isosurface", || {
            Ok(self.surface.warnings.clone())
        })
    }

    /// Where a piece's point data comes from: the surface's sources, then the carrier's points.
    pub fn piece_sources(
        &self,
        whole: &GridSpec,
        owned: &[i64],
    ) -> Result<Box<PointSources>, String> {
        let sources = self
            .surface
            .sources
            .as_flattened()
            .iter()
            .map(|&i| i as u64);
        let carrier = self.carrier.iter().flat_map(|m| &m.0.point_ids);
        piece::point_sources(whole, owned, sources.chain(carrier.map(|&i| i as u64)))
    }

    /// Moves the carrier tetrahedra out (once).
    pub fn take_carrier(&mut self) -> Result<Box<Mesh>, String> {
        guard("reading the isosurface", || {
            self.carrier.take().ok_or_else(|| {
                "no carrier tetrahedra: not asked for (IsoSpec::carrier_tetrahedra) or already taken"
                    .to_string()
            })
        })
    }

    /// The surface as the core returned it (its carrier is taken with [`Surface::take_carrier`]).
    pub fn inner(&self) -> &IsoSurface {
        &self.surface
    }
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn guard_turns_a_panic_into_an_error() {
        let r: Result<(), String> = guard("testing", || panic!("boom {}", 7));
        let msg = r.unwrap_err();
        assert!(msg.contains("while testing"), "{msg}");
        assert!(msg.contains("boom 7"), "{msg}");
        let r: Result<(), String> = guard("testing", || panic!("static"));
        assert!(r.unwrap_err().contains("static"));
    }

    #[test]
    fn guard_passes_results_through() {
        assert_eq!(guard("x", || Ok(3)), Ok(3));
        assert_eq!(guard::<()>("x", || Err("no".into())), Err("no".into()));
    }

    #[test]
    fn typed_slice_reads_in_place() {
        let values = [1.5f64, -2.0, 3.25];
        let bytes: &[u8] = bytemuck::cast_slice(&values);
        match typed_slice(ScalarType::F64, bytes).unwrap() {
            ScalarSlice::F64(s) => {
                assert_eq!(s, &values);
                assert_eq!(s.as_ptr() as *const u8, bytes.as_ptr());
            }
            other => panic!("wrong variant {other:?}"),
        }
        let shorts = [7i16, -9];
        match typed_slice(ScalarType::I16, bytemuck::cast_slice(&shorts)).unwrap() {
            ScalarSlice::I16(s) => assert_eq!(s, &shorts),
            other => panic!("wrong variant {other:?}"),
        }
    }

    #[test]
    fn typed_slice_refuses_ragged_or_misaligned_buffers() {
        let values = [0u32; 4];
        let bytes: &[u8] = bytemuck::cast_slice(&values);
        assert!(typed_slice(ScalarType::U32, &bytes[..7]).is_err());
        assert!(typed_slice(ScalarType::U32, &bytes[1..5]).is_err());
        assert!(typed_slice(ScalarType { repr: 200 }, bytes).is_err());
    }

    fn small_volume() -> (GridSpec, Vec<f64>) {
        let grid = GridSpec {
            dims: [5, 4, 3],
            origin: [1.0, -2.0, 0.5],
            spacing: [0.5, 1.0, 2.0],
        };
        let values = (0..60).map(|i| ((i * 7) % 11) as f64 * 0.25).collect();
        (grid, values)
    }

    #[test]
    fn builds_and_queries_through_the_bridge() {
        let (grid, values) = small_volume();
        let mut reports = 0;
        let mut progress = |f: f64| {
            assert!((0.0..=1.0).contains(&f));
            reports += 1;
            true
        };
        let h = build_with(
            &grid,
            ScalarType::F64,
            bytemuck::cast_slice(&values),
            &mut progress,
        )
        .unwrap();
        assert!(reports > 0);
        let query = QuerySpec {
            tolerance: 0.0,
            max_tetrahedra: 0,
            use_region_of_interest: false,
            region_of_interest: [0.0; 6],
        };
        let plan = h.plan_mesh(&query).unwrap();
        let (n, np) = (plan.number_of_tetrahedra(), plan.number_of_points());
        assert!(n > 0 && np <= 60);
        // What C++ allocates and has written equals the core's own mesh.
        let mesh = h.hierarchy.query(&Query::tolerance(0.0)).unwrap();
        let (mut conn, mut offsets) = (vec![0i32; 4 * n], vec![0i32; n + 1]);
        let (mut depths, mut errors) = (vec![0u8; n], vec![0f32; n]);
        let max = h
            .write_tets_i32(&plan, &mut conn, &mut offsets, &mut depths, &mut errors)
            .unwrap();
        assert_eq!(max, 0.0);
        assert!(conn
            .iter()
            .zip(mesh.tets.as_flattened())
            .all(|(&a, &b)| a as u32 == b));
        assert_eq!((depths, errors), (mesh.depths.clone(), mesh.errors.clone()));
        assert_eq!(offsets[n], 4 * n as i32);
        let mut ids = vec![0i64; np];
        plan.write_point_ids(&mut ids).unwrap();
        assert!(ids
            .iter()
            .zip(&mesh.point_ids)
            .all(|(&a, &b)| a as usize == b));
        // Extent minima (1, 0, 2): the points are shifted by one and two spacings.
        let frame = PointFrame {
            origin: grid.origin,
            first_index: [1, 0, 2],
            spacing: grid.spacing,
        };
        let mut xyz = vec![0.0; 3 * np];
        plan.write_points(&frame, &mut xyz).unwrap();
        for (p, q) in xyz.chunks(3).zip(&mesh.points) {
            assert_eq!([p[0] - 0.5, p[1], p[2] - 4.0], *q);
        }
        let bytes: &[u8] = bytemuck::cast_slice(&values);
        let mut passed = vec![0f64; np];
        plan.gather_point_values(bytes, 8, bytemuck::cast_slice_mut(&mut passed))
            .unwrap();
        assert!(passed
            .iter()
            .zip(&ids)
            .all(|(&v, &i)| v == values[i as usize]));
        // Wrong sizes and another hierarchy's plan are errors, not writes out of bounds.
        assert!(plan.write_points(&frame, &mut xyz[1..]).is_err());
        let other = build_with(&grid, ScalarType::F64, bytes, &mut |_| true).unwrap();
        let err = other
            .write_tets_i64(&plan, &mut [0; 0], &mut [], &mut [], &mut [])
            .unwrap_err();
        assert!(err.contains("another hierarchy"), "{err}");
    }

    #[test]
    fn bad_inputs_and_abort_are_errors() {
        let (grid, values) = small_volume();
        let bytes: &[u8] = bytemuck::cast_slice(&values);
        let abort = build_with(&grid, ScalarType::F64, bytes, &mut |_| false);
        assert_eq!(abort.err().as_deref(), Some("aborted"));
        let short = build_with(&grid, ScalarType::F64, &bytes[..8 * 59], &mut |_| true);
        assert!(short.err().unwrap().contains("59 values"));
        let h = build_with(&grid, ScalarType::F64, bytes, &mut |_| true).unwrap();
        let negative = QuerySpec {
            tolerance: -1.0,
            max_tetrahedra: 0,
            use_region_of_interest: false,
            region_of_interest: [0.0; 6],
        };
        assert!(h.plan_mesh(&negative).err().unwrap().contains("tolerance"));
    }

    #[test]
    fn a_core_violation_becomes_an_error() {
        assert_eq!(check_core(Ok(())), Ok(()));
        let e = check_core(Err("3 tetrahedra but 2 depths".into())).unwrap_err();
        assert_eq!(
            e,
            "internal error in the Diamonds core: 3 tetrahedra but 2 depths"
        );
    }

    /// A distance field to a point on a 17^3 grid (spacing 0.5): the isosurface `r` is a sphere.
    fn sphere_volume() -> (GridSpec, Vec<f32>) {
        let grid = GridSpec {
            dims: [17, 17, 17],
            origin: [-4.0, -4.0, -4.0],
            spacing: [0.5, 0.5, 0.5],
        };
        let mut values = Vec::with_capacity(17 * 17 * 17);
        for k in 0..17 {
            for j in 0..17 {
                for i in 0..17 {
                    let p = [i, j, k].map(|c| -4.0 + 0.5 * c as f64);
                    let r = ((p[0] - 0.3).powi(2) + (p[1] + 0.2).powi(2) + p[2].powi(2)).sqrt();
                    values.push(r as f32);
                }
            }
        }
        (grid, values)
    }

    /// Both kinds of hierarchy of the same `f32` samples, named: the full one ([`build_hierarchy`],
    /// what Adaptive Tetrahedra builds) and the isosurface-only one ([`build_isosurface_hierarchy`],
    /// what Adaptive Isosurface builds).
    fn both_kinds(grid: &GridSpec, bytes: &[u8]) -> [(&'static str, Box<Hierarchy>); 2] {
        [
            (
                "full",
                Box::new(build_with(grid, ScalarType::F32, bytes, &mut |_| true).unwrap()),
            ),
            (
                "isosurface-only",
                build_isosurface_hierarchy(grid, ScalarType::F32, bytes).unwrap(),
            ),
        ]
    }

    fn iso_spec(tolerance: f64) -> IsoSpec {
        IsoSpec {
            tolerance,
            max_triangles: 0,
            use_region_of_interest: false,
            region_of_interest: [0.0; 6],
            compute_normals: true,
            carrier_tetrahedra: true,
        }
    }

    fn fresh() -> IsoState {
        IsoState::default()
    }

    fn same(a: &Surface, b: &Surface) -> bool {
        let (a, b) = (a.inner(), b.inner());
        a.points == b.points && a.triangles == b.triangles && a.values == b.values
    }

    /// The carrier's per-tetrahedron errors: one per tetrahedron, finite, non-negative, and the
    /// largest is both the mesh's `max_error` and the surface's `error_bound` (the isosurface error
    /// of the diamonds carrying the surface, world units). Returns them.
    fn carrier_errors(surface: &mut Surface, what: &str) -> Vec<f32> {
        let bound = surface.error_bound();
        let carrier = surface.take_carrier().unwrap();
        let errors = carrier.errors().to_vec();
        assert_eq!(errors.len(), carrier.tets().len() / 4, "{what}");
        assert!(!errors.is_empty(), "{what}: no carrier tetrahedra");
        assert!(
            errors.iter().all(|e| e.is_finite() && *e >= 0.0),
            "{what}: {errors:?}"
        );
        let max = errors.iter().fold(0.0f64, |m, &e| m.max(e as f64));
        assert_eq!(max, carrier.max_error(), "{what}");
        assert_eq!(max, bound, "{what}: largest carrier error = error bound");
        errors
    }

    #[test]
    fn isosurface_state_reuses_the_mesh_only_when_refinement_did_not_change() {
        let (grid, values) = sphere_volume();
        let bytes: &[u8] = bytemuck::cast_slice(&values);
        for (kind, h) in both_kinds(&grid, bytes) {
            let mut state = new_iso_state();
            assert!(
                !state.reused(),
                "{kind}: nothing to reuse before the first query"
            );
            let spec = iso_spec(0.25);
            let first = h
                .isosurface(&mut state, ScalarType::F32, bytes, &[2.5], &spec)
                .unwrap();
            assert!(!state.reused(), "{kind}");
            // Normals and carrier off: same refinement, the mesh is reused, same triangles.
            let bare = IsoSpec {
                compute_normals: false,
                carrier_tetrahedra: false,
                ..spec
            };
            let again = h
                .isosurface(&mut state, ScalarType::F32, bytes, &[2.5], &bare)
                .unwrap();
            assert!(state.reused(), "{kind}");
            assert!(same(&first, &again) && again.normals().is_empty(), "{kind}");
            // An isovalue change refines (from the root) and equals a fresh query.
            let changed = h
                .isosurface(&mut state, ScalarType::F32, bytes, &[3.0], &bare)
                .unwrap();
            assert!(!state.reused(), "{kind}");
            let reference = h
                .isosurface(&mut fresh(), ScalarType::F32, bytes, &[3.0], &bare)
                .unwrap();
            assert!(same(&changed, &reference), "{kind}");
            // A tolerance change too.
            let finer = IsoSpec {
                tolerance: 0.1,
                ..bare
            };
            h.isosurface(&mut state, ScalarType::F32, bytes, &[3.0], &finer)
                .unwrap();
            assert!(!state.reused(), "{kind}");
            // A failed query clears the state: the next one refines again.
            assert!(h
                .isosurface(&mut state, ScalarType::F32, bytes, &[f64::NAN], &finer)
                .is_err());
            assert!(!state.reused(), "{kind}");
            h.isosurface(&mut state, ScalarType::F32, bytes, &[3.0], &finer)
                .unwrap();
            assert!(!state.reused(), "{kind}");
            h.isosurface(&mut state, ScalarType::F32, bytes, &[3.0], &finer)
                .unwrap();
            assert!(state.reused(), "{kind}");
        }
    }

    #[test]
    fn isosurface_only_hierarchy_serves_isosurfaces_and_refuses_meshes() {
        let (grid, values) = sphere_volume();
        let bytes: &[u8] = bytemuck::cast_slice(&values);
        let [(_, full), (_, iso)] = both_kinds(&grid, bytes);
        assert_ne!(full.id, iso.id);
        // Each build gets a new id, whatever its kind.
        let again = build_isosurface_hierarchy(&grid, ScalarType::F32, bytes).unwrap();
        assert!(again.id != iso.id && again.id != full.id);
        assert_eq!(iso.metadata_bytes(), 0);
        assert_eq!(full.metadata_bytes(), 2 * values.len());
        let err = iso
            .plan_mesh(&QuerySpec {
                tolerance: 0.1,
                max_tetrahedra: 0,
                use_region_of_interest: false,
                region_of_interest: [0.0; 6],
            })
            .map(|_| ())
            .unwrap_err();
        assert!(err.contains("isosurfaces only"), "{err}");
        // The same surfaces and carrier errors from both, at full resolution and adaptively.
        for tolerance in [0.0, 0.25, 0.6] {
            let spec = iso_spec(tolerance);
            let mut a = full
                .isosurface(&mut fresh(), ScalarType::F32, bytes, &[2.5], &spec)
                .unwrap();
            let mut b = iso
                .isosurface(&mut fresh(), ScalarType::F32, bytes, &[2.5], &spec)
                .unwrap();
            assert!(
                same(&a, &b) && !b.triangles().is_empty(),
                "tolerance {tolerance}"
            );
            assert_eq!(a.error_bound(), b.error_bound());
            assert_eq!(
                carrier_errors(&mut a, "full"),
                carrier_errors(&mut b, "isosurface-only"),
                "tolerance {tolerance}"
            );
        }
        // Bad input is an error, not a panic.
        assert!(build_isosurface_hierarchy(&grid, ScalarType::F32, &bytes[4..]).is_err());
        let mut nan = values.clone();
        nan[100] = f32::NAN;
        assert!(
            build_isosurface_hierarchy(&grid, ScalarType::F32, bytemuck::cast_slice(&nan)).is_err()
        );
        let flat = GridSpec {
            dims: [17, 17, 1],
            ..grid
        };
        assert!(build_isosurface_hierarchy(&flat, ScalarType::F32, &bytes[..4 * 17 * 17]).is_err());
    }

    #[test]
    fn carrier_errors_are_isosurface_errors_in_world_units() {
        // Unlike an approximation error (data units), the isosurface error ae / |grad| does not
        // change when the data are scaled, and scales with the spacing. Powers of two keep every
        // step exact, so the refinement and the errors compare exactly.
        let (grid, values) = sphere_volume();
        let bytes: &[u8] = bytemuck::cast_slice(&values);
        let doubled: Vec<f32> = values.iter().map(|v| 2.0 * v).collect();
        let doubled_bytes: &[u8] = bytemuck::cast_slice(&doubled);
        let stretched = GridSpec {
            origin: grid.origin.map(|o| 2.0 * o),
            spacing: grid.spacing.map(|s| 2.0 * s),
            ..grid
        };
        for (kind, h) in both_kinds(&grid, bytes) {
            for tolerance in [0.25, 0.6] {
                let what = format!("{kind}, tolerance {tolerance}");
                let mut base = h
                    .isosurface(
                        &mut fresh(),
                        ScalarType::F32,
                        bytes,
                        &[2.5],
                        &iso_spec(tolerance),
                    )
                    .unwrap();
                let errors = carrier_errors(&mut base, &what);
                assert!(
                    errors.iter().any(|&e| e > 0.0),
                    "{what}: an adaptive surface has tetrahedra with an error"
                );
                assert!(base.error_bound() <= tolerance, "{what}");

                let scaled =
                    build_isosurface_hierarchy(&grid, ScalarType::F32, doubled_bytes).unwrap();
                let mut s = scaled
                    .isosurface(
                        &mut fresh(),
                        ScalarType::F32,
                        doubled_bytes,
                        &[5.0],
                        &iso_spec(tolerance),
                    )
                    .unwrap();
                assert_eq!(
                    carrier_errors(&mut s, &what),
                    errors,
                    "{what}: data scaled by 2, same errors"
                );

                let wide = build_isosurface_hierarchy(&stretched, ScalarType::F32, bytes).unwrap();
                let mut w = wide
                    .isosurface(
                        &mut fresh(),
                        ScalarType::F32,
                        bytes,
                        &[2.5],
                        &iso_spec(2.0 * tolerance),
                    )
                    .unwrap();
                let doubled_errors: Vec<f32> = errors.iter().map(|e| 2.0 * e).collect();
                assert_eq!(
                    carrier_errors(&mut w, &what),
                    doubled_errors,
                    "{what}: spacing scaled by 2, errors doubled"
                );
            }
        }
    }

    #[test]
    fn isosurface_state_is_not_reused_on_another_hierarchy() {
        let (grid, values) = sphere_volume();
        let bytes: &[u8] = bytemuck::cast_slice(&values);
        // Same grid (same lattice), other samples: the split set of `h` must not be reused.
        let shifted: Vec<f32> = values.iter().map(|v| 2.0 * v).collect();
        let other_bytes: &[u8] = bytemuck::cast_slice(&shifted);
        for ((kind, h), (other_kind, other)) in both_kinds(&grid, bytes)
            .into_iter()
            .zip(both_kinds(&grid, other_bytes).into_iter().rev())
        {
            let what = format!("{kind}, then {other_kind}");
            let mut state = fresh();
            let spec = iso_spec(0.25);
            h.isosurface(&mut state, ScalarType::F32, bytes, &[2.5], &spec)
                .unwrap();
            let s = other
                .isosurface(&mut state, ScalarType::F32, other_bytes, &[2.5], &spec)
                .unwrap();
            assert!(
                !state.reused(),
                "{what}: a state of another hierarchy is cleared"
            );
            let reference = other
                .isosurface(&mut fresh(), ScalarType::F32, other_bytes, &[2.5], &spec)
                .unwrap();
            assert!(same(&s, &reference), "{what}");
            other
                .isosurface(&mut state, ScalarType::F32, other_bytes, &[2.5], &spec)
                .unwrap();
            assert!(state.reused(), "{what}");
        }
    }

    #[test]
    fn isosurface_through_the_bridge() {
        let (grid, values) = sphere_volume();
        let bytes: &[u8] = bytemuck::cast_slice(&values);
        for (kind, h) in both_kinds(&grid, bytes) {
            for tolerance in [0.0, 0.25] {
                let what = format!("{kind}, tolerance {tolerance}");
                let s = h
                    .isosurface(
                        &mut fresh(),
                        ScalarType::F32,
                        bytes,
                        &[2.5],
                        &iso_spec(tolerance),
                    )
                    .unwrap();
                let points = s.points();
                let n = points.len() / 3;
                let triangles = s.triangles();
                assert!(n > 0 && !triangles.is_empty(), "{what}");
                assert!(triangles.chunks_exact(3).remainder().is_empty());
                assert!(triangles.iter().all(|&c| (c as usize) < n));
                assert_eq!(s.values(), vec![2.5; n].as_slice());
                let normals = s.normals();
                assert_eq!(normals.len(), 3 * n);
                for v in normals.chunks(3) {
                    let len = (v[0] * v[0] + v[1] * v[1] + v[2] * v[2]).sqrt();
                    assert!((len - 1.0).abs() < 1e-3, "{what}: normal {v:?}");
                }
                // Every vertex near the sphere of radius 2.5 around (0.3, -0.2, 0).
                for p in points.chunks(3) {
                    let r = ((p[0] - 0.3).powi(2) + (p[1] + 0.2).powi(2) + p[2].powi(2)).sqrt();
                    assert!(
                        (r - 2.5).abs() < tolerance + 0.5,
                        "{what}: vertex {p:?} at r = {r}"
                    );
                }
                assert!(s.error_bound() <= tolerance + 1e-12, "{what}");
                let mut s = s;
                assert!(s.has_carrier());
                let carrier = s.take_carrier().unwrap();
                assert!(!carrier.tets().is_empty(), "{what}");
                assert!(carrier.point_ids().iter().all(|&id| id < values.len()));
                assert!(!s.has_carrier());
                assert!(s.take_carrier().err().unwrap().contains("already taken"));
            }
        }
    }

    #[test]
    fn isosurface_without_carrier_or_normals() {
        let (grid, values) = sphere_volume();
        let bytes: &[u8] = bytemuck::cast_slice(&values);
        for (kind, h) in both_kinds(&grid, bytes) {
            let spec = IsoSpec {
                compute_normals: false,
                carrier_tetrahedra: false,
                ..iso_spec(0.1)
            };
            let mut s = h
                .isosurface(&mut fresh(), ScalarType::F32, bytes, &[1.5, 3.0], &spec)
                .unwrap();
            assert!(s.normals().is_empty(), "{kind}");
            assert!(!s.has_carrier(), "{kind}");
            assert!(s.take_carrier().err().unwrap().contains("not asked for"));
            let values_seen: std::collections::BTreeSet<u64> =
                s.values().iter().map(|v| v.to_bits()).collect();
            assert_eq!(values_seen.len(), 2, "{kind}: two isovalues, two surfaces");
        }
    }

    #[test]
    fn isosurface_bad_inputs_are_errors() {
        let (grid, values) = sphere_volume();
        let bytes: &[u8] = bytemuck::cast_slice(&values);
        for (kind, h) in both_kinds(&grid, bytes) {
            let short = h.isosurface(
                &mut fresh(),
                ScalarType::F32,
                &bytes[..4 * 100],
                &[2.5],
                &iso_spec(0.0),
            );
            assert!(short.err().unwrap().contains("100 values"), "{kind}");
            let negative = h.isosurface(
                &mut fresh(),
                ScalarType::F32,
                bytes,
                &[2.5],
                &iso_spec(-1.0),
            );
            assert!(negative.err().unwrap().contains("tolerance"), "{kind}");
            let nan = h.isosurface(
                &mut fresh(),
                ScalarType::F32,
                bytes,
                &[f64::NAN],
                &iso_spec(0.0),
            );
            assert!(nan.is_err(), "{kind}");
        }
    }
}
