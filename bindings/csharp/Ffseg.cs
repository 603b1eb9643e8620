// Ffseg.cs - C# wrapper over ffseg's C ABI (include/ffseg.h), for Mono and .NET.
// Build: mcs -unsafe -target:library -out:Ffseg.dll Ffseg.cs
//
// What the header asks of a P/Invoke binding, and why it is done this way:
//  - structs are blittable (fixed buffers, no ByValArray, no bool), so they are
//    passed by pointer with no marshalling copy, and their layout is what the C
//    compiler's is (tests/Tests.cs compares every offset with abi/layout.c's);
//  - strings come back as IntPtr and are copied out: a `string` return type
//    makes the marshaller free the library's static text (Mono aborts);
//  - the library is loaded by its soname, libffseg.so.0, which the runtime
//    package installs; "ffseg" would only find the development link libffseg.so;
//  - the workspace is over-allocated and aligned to 64 bytes by hand
//    (AllocHGlobal gives 16);
//  - array arguments of fixed length (centre, affine) are checked here: the
//    marshaller passes whatever length it is given.
using System;
using System.Runtime.InteropServices;

namespace Ffseg {

public static class Status {
  public const int Ok = 0;
  public const int Converged = 1;
  // Every object at rest, but some result is no segmentation, or only part of
  // one (StepInfo.ObjectFlags).
  public const int Degenerate = 2;
  // StepInfo.ObjectFlags / FlagsAll bits.
  public const uint ObjectNoBoundary = 1;
  public const uint ObjectFillsGrid = 2;
  // Since 0.5.0: came to rest short of (or beyond) its boundary; a partial
  // result (StepInfo.FarOutward / FarInward give the counts).
  public const uint ObjectStalled = 4;
  public const int ErrInvalidArgument = -1;
  public const int ErrNullPointer = -2;
  public const int ErrWorkspaceTooSmall = -3;
  public const int ErrWorkspaceMisaligned = -4;
  public const int ErrInvalidVolume = -5;
  public const int ErrObjectOutOfRange = -6;
  public const int ErrBufferTooSmall = -7;
  public const int ErrMisuse = -8;
  public const int ErrNumeric = -9;
  public const int ErrRoiTooLarge = -10;
  public const int ErrSphereOutside = -11;
  public const int ErrStructSize = -12;
  public const int ErrConfigTooLarge = -13;
  public const int ErrNotImplemented = -14;

  // ffseg_status_string: static text for a status code.
  public static string Text(int status) {
    return Marshal.PtrToStringAnsi(Native.ffseg_status_string(status));
  }
}

public static class VoxelType {
  public const uint U8 = 1, I16 = 2, U16 = 3, I32 = 4, F32 = 5, F64 = 6;
}

public static class TargetMode {
  public const uint Binary = 0, Intensity = 1;
}

public static class Limits {
  public const int ReportObjects = 16;
  public const int StageCount = 10;
}

// ffseg_config. Config.Default() is the library's default.
[StructLayout(LayoutKind.Sequential)]
public struct Config {
  public uint StructSize;
  public uint MaxObjects;
  public uint MeshResolution;
  public uint Reserved0;
  public long MaxRoiVoxels;
  public uint TargetMode;  // FFSEG_TARGET_INTENSITY (default) or FFSEG_TARGET_BINARY: binary only, smaller workspace
  public uint Reserved1;
  // Since 0.6.0: several objects, the voxels one bounding region is marched on
  // (0: MaxRoiVoxels); a larger box is marched on coarser cells.
  public long MaxRegionVoxels;

  public static Config Default() {
    Config c;
    Native.ffseg_config_init_default(out c);
    return c;
  }
}

// ffseg_params. Params.Default() is the library's default.
[StructLayout(LayoutKind.Sequential)]
public struct Params {
  public uint StructSize;
  public uint TargetMode;
  public double LambdaLaplacian;
  public double LambdaPosition;
  public double LambdaUniform;
  public double StepSize;
  public double FlipTau;
  public double SearchRangeMm;
  public double SearchStepMm;
  public double ConvergenceMm;
  public uint DiffusionIterations;
  public uint ConsecutiveBackground;
  public uint SmoothingIterations;
  public uint BinMinCount;
  public double SmoothingKappa;
  public double IntensityGamma;
  public double SigmaFloorFraction;
  public double BinRadius;
  public double BinSeparation;
  public uint PartialVolumeSteps;
  public uint Reserved1;
  public double RegionWidthMm;   // several objects (0.3.0): 0 = automatic, 10 mm
  public double BorderWeight;
  public uint RegionInterval;
  public uint GreyRespacing;     // 0.7.0 (Reserved2 before): grey levels re-space their loops until the first rest; 0.8.0: 0 automatic, 1 always, 2 never

  public static Params Default() {
    Params p;
    Native.ffseg_params_init_default(out p);
    return p;
  }
}

// ffseg_volume. Built by Engine.SetVolume; public for callers with their own buffers.
[StructLayout(LayoutKind.Sequential)]
public unsafe struct Volume {
  public uint StructSize;
  public uint VoxelType;
  public IntPtr Data;
  public ulong DataBytes;
  public long Offset;
  public fixed long Dims[3];
  public fixed long Strides[3];
  public fixed double IndexToWorld[16];
  public double RescaleSlope;
  public double RescaleIntercept;
}

// ffseg_step_info: what one step did.
[StructLayout(LayoutKind.Sequential)]
public unsafe struct StepInfo {
  public uint StructSize;
  public uint StepIndex;
  public uint ActiveObjects;
  public uint Reserved0;
  public fixed double MeanDisplacementMm[16];
  public fixed uint VerticesWithTarget[16];
  public fixed uint FlipsAvoided[16];
  public fixed uint IntersectionsAvoided[16];
  public fixed uint BorderVertices[16];
  public fixed ulong StageUs[10];
  public fixed uint ObjectFlags[16];
  public uint FlagsAll;
  public uint Reserved1;
  // Since 0.5.0, per object: vertices the step guard held back, and those
  // whose target lay more than a voxel outward / inward.
  public fixed uint GuardHeld[16];
  public fixed uint FarOutward[16];
  public fixed uint FarInward[16];
  // Since 0.8.0: 1 where the object's mesh re-spaced its contour loops.
  public fixed uint Respaced[16];
}

internal static class Native {
  const string Lib = "libffseg.so.0";
  [DllImport(Lib)] public static extern uint ffseg_version_number();
  [DllImport(Lib)] public static extern IntPtr ffseg_status_string(int s);
  [DllImport(Lib)] public static extern IntPtr ffseg_last_error(IntPtr e);
  [DllImport(Lib)] public static extern void ffseg_config_init_default(out Config c);
  [DllImport(Lib)] public static extern int ffseg_workspace_size(ref Config c, out UIntPtr bytes);
  [DllImport(Lib)] public static extern int ffseg_create(ref Config c, IntPtr workspace, UIntPtr bytes, out IntPtr engine);
  [DllImport(Lib)] public static extern void ffseg_destroy(IntPtr e);
  [DllImport(Lib)] public static extern void ffseg_params_init_default(out Params p);
  [DllImport(Lib)] public static extern int ffseg_set_params(IntPtr e, ref Params p);
  [DllImport(Lib)] public static extern int ffseg_set_volume(IntPtr e, ref Volume v);
  [DllImport(Lib)] public static extern int ffseg_sample(IntPtr e, double[] pointMm, uint mode, out double value);
  [DllImport(Lib)] public static extern int ffseg_init_sphere(IntPtr e, uint obj, double[] centerMm, double radiusMm);
  [DllImport(Lib)] public static extern int ffseg_init_mesh(IntPtr e, uint obj, double[] centerMm, double radiusMm,
                                                            float[] xyz, UIntPtr nVertices);
  [DllImport(Lib)] public static extern int ffseg_step(IntPtr e, ref StepInfo info);
  [DllImport(Lib)] public static extern int ffseg_extract_mesh(IntPtr e, uint obj, float[] xyz, UIntPtr xyzCapacity,
                                                               uint[] tris, UIntPtr triCapacity,
                                                               out UIntPtr nVertices, out UIntPtr nTris);
  [DllImport(Lib)] public static extern int ffseg_rasterize(IntPtr e, uint obj, byte[] mask, IntPtr strides);
  [DllImport(Lib)] public static extern int ffseg_region_mask(IntPtr e, uint obj, byte[] mask, IntPtr strides);
}

// A failed call: its status (Status.Err*) and ffseg_last_error's message.
public sealed class FfsegException : Exception {
  public int Status { get; private set; }
  public string Detail { get; private set; }
  public FfsegException(int status, string detail)
      : base(Ffseg.Status.Text(status) + " (" + status + ")" + (detail.Length > 0 ? ": " + detail : "")) {
    Status = status;
    Detail = detail;
  }
}

public static class Library {
  // MAJOR*10000 + MINOR*100 + PATCH of the loaded library.
  public static uint Version { get { return Native.ffseg_version_number(); } }
}

// An engine in a workspace it owns. Dispose (or the finalizer) destroys the
// engine, frees the workspace and unpins the volume's voxels.
public sealed class Engine : IDisposable {
  IntPtr raw_;        // ffseg_engine*
  IntPtr block_;      // what AllocHGlobal returned
  IntPtr workspace_;  // block_ rounded up to 64 bytes
  long bytes_;
  GCHandle pinned_;   // the voxels of the volume the engine holds
  long voxels_;       // that volume's voxel count (what Rasterize writes)

  public Engine(Config config) {
    UIntPtr n;
    Check(Native.ffseg_workspace_size(ref config, out n), IntPtr.Zero);
    bytes_ = (long)n.ToUInt64();
    block_ = Marshal.AllocHGlobal(new IntPtr(bytes_ + 63));
    workspace_ = new IntPtr((block_.ToInt64() + 63) & ~63L);
    IntPtr e;
    int st = Native.ffseg_create(ref config, workspace_, n, out e);
    if (st < 0) {
      string msg = Marshal.PtrToStringAnsi(Native.ffseg_last_error(IntPtr.Zero));
      Marshal.FreeHGlobal(block_);
      block_ = IntPtr.Zero;
      throw new FfsegException(st, msg);
    }
    raw_ = e;
  }

  ~Engine() { Release(); }

  public void Dispose() {
    Release();
    GC.SuppressFinalize(this);
  }

  void Release() {
    if (raw_ != IntPtr.Zero) Native.ffseg_destroy(raw_);
    raw_ = IntPtr.Zero;
    if (block_ != IntPtr.Zero) Marshal.FreeHGlobal(block_);
    block_ = IntPtr.Zero;
    if (pinned_.IsAllocated) pinned_.Free();
  }

  public long WorkspaceBytes { get { return bytes_; } }
  public IntPtr WorkspaceAddress { get { return workspace_; } }
  public bool VolumePinned { get { return pinned_.IsAllocated; } }

  IntPtr Live() {
    if (raw_ == IntPtr.Zero) throw new ObjectDisposedException("Ffseg.Engine");
    return raw_;
  }

  static int Check(int st, IntPtr e) {
    if (st < 0) throw new FfsegException(st, Marshal.PtrToStringAnsi(Native.ffseg_last_error(e)));
    return st;
  }

  public void SetParams(Params p) { Check(Native.ffseg_set_params(Live(), ref p), raw_); }

  // Contiguous voxels, i fastest; dims = {nx, ny, nz}; indexToWorld: row-major
  // 4x4, 16 values (null: the identity, 1 mm voxels). The array stays pinned
  // until the next successful SetVolume or Dispose.
  public void SetVolume(byte[] v, long[] dims, double[] indexToWorld = null, double slope = 1, double intercept = 0) {
    SetVolume(v, VoxelType.U8, 1, dims, indexToWorld, slope, intercept);
  }
  public void SetVolume(short[] v, long[] dims, double[] indexToWorld = null, double slope = 1, double intercept = 0) {
    SetVolume(v, VoxelType.I16, 2, dims, indexToWorld, slope, intercept);
  }
  public void SetVolume(ushort[] v, long[] dims, double[] indexToWorld = null, double slope = 1, double intercept = 0) {
    SetVolume(v, VoxelType.U16, 2, dims, indexToWorld, slope, intercept);
  }
  public void SetVolume(int[] v, long[] dims, double[] indexToWorld = null, double slope = 1, double intercept = 0) {
    SetVolume(v, VoxelType.I32, 4, dims, indexToWorld, slope, intercept);
  }
  public void SetVolume(float[] v, long[] dims, double[] indexToWorld = null, double slope = 1, double intercept = 0) {
    SetVolume(v, VoxelType.F32, 4, dims, indexToWorld, slope, intercept);
  }
  public void SetVolume(double[] v, long[] dims, double[] indexToWorld = null, double slope = 1, double intercept = 0) {
    SetVolume(v, VoxelType.F64, 8, dims, indexToWorld, slope, intercept);
  }

  // Axis-aligned voxels of this size in mm, voxel (0,0,0) at the origin.
  public static double[] Spacing(double sx, double sy, double sz) {
    return new double[] { sx, 0, 0, 0, 0, sy, 0, 0, 0, 0, sz, 0, 0, 0, 0, 1 };
  }

  unsafe void SetVolume(Array voxels, uint type, int elem, long[] dims, double[] affine, double slope, double intercept) {
    IntPtr e = Live();
    if (voxels == null) throw new ArgumentNullException("voxels");
    if (dims == null || dims.Length != 3) throw new ArgumentException("dims must hold 3 values", "dims");
    if (affine == null) affine = Spacing(1, 1, 1);
    if (affine.Length != 16) throw new ArgumentException("indexToWorld must hold 16 values (row-major 4x4)", "indexToWorld");
    GCHandle pin = GCHandle.Alloc(voxels, GCHandleType.Pinned);
    Volume v = new Volume();
    v.StructSize = (uint)sizeof(Volume);
    v.VoxelType = type;
    v.Data = pin.AddrOfPinnedObject();
    v.DataBytes = (ulong)voxels.LongLength * (ulong)elem;
    v.Offset = 0;
    v.Dims[0] = dims[0]; v.Dims[1] = dims[1]; v.Dims[2] = dims[2];
    v.Strides[0] = elem; v.Strides[1] = elem * dims[0]; v.Strides[2] = elem * dims[0] * dims[1];
    for (int q = 0; q < 16; ++q) v.IndexToWorld[q] = affine[q];
    v.RescaleSlope = slope;
    v.RescaleIntercept = intercept;
    int st = Native.ffseg_set_volume(e, ref v);
    if (st < 0) {
      // The engine keeps its previous volume, so that one stays pinned.
      string msg = Marshal.PtrToStringAnsi(Native.ffseg_last_error(e));
      pin.Free();
      throw new FfsegException(st, msg);
    }
    if (pinned_.IsAllocated) pinned_.Free();
    pinned_ = pin;
    voxels_ = dims[0] * dims[1] * dims[2];
  }

  public void InitSphere(uint obj, double[] centerMm, double radiusMm) {
    if (centerMm == null || centerMm.Length != 3) throw new ArgumentException("centerMm must hold 3 values", "centerMm");
    Check(Native.ffseg_init_sphere(Live(), obj, centerMm, radiusMm), raw_);
  }

  // Places an object's mesh from another engine's (coarse to fine): xyz as
  // ExtractMesh gives it, 3 floats per vertex, from an engine of any mesh
  // resolution n (6 n^2 vertices), resampled onto this engine's. The
  // grey-level model comes from the sphere (centerMm, radiusMm) as InitSphere's
  // does: give the sphere the mesh grew from. On failure the object keeps the
  // mesh it had.
  public void InitMesh(uint obj, double[] centerMm, double radiusMm, float[] xyz) {
    if (centerMm == null || centerMm.Length != 3) throw new ArgumentException("centerMm must hold 3 values", "centerMm");
    if (xyz == null) throw new ArgumentNullException("xyz");
    // The count passed is xyz.Length / 3: a partial vertex would be dropped silently.
    if (xyz.Length % 3 != 0) throw new ArgumentException("xyz must hold 3 floats per vertex", "xyz");
    Check(Native.ffseg_init_mesh(Live(), obj, centerMm, radiusMm, xyz, new UIntPtr((ulong)(xyz.Length / 3))), raw_);
  }

  // The last Step's status (Status.Ok, Converged or Degenerate).
  public int LastStatus { get; private set; }
  // The last Step's StepInfo.FlagsAll: every object's Status.Object* flags or-ed.
  public uint LastFlagsAll { get; private set; }
  // Some object stalled short of (or beyond) its boundary at the last Step
  // (LastStatus is then Degenerate).
  public bool Stalled { get { return (LastFlagsAll & Status.ObjectStalled) != 0; } }

  // One deformation step; true once every object has converged.
  public unsafe bool Step(out StepInfo info) {
    info = new StepInfo();
    info.StructSize = (uint)sizeof(StepInfo);
    LastStatus = Check(Native.ffseg_step(Live(), ref info), raw_);
    LastFlagsAll = info.FlagsAll;
    return LastStatus == Status.Converged;
  }

  // Steps until every object is at rest (converged, or Degenerate: see
  // LastStatus, Stalled and StepInfo.ObjectFlags) or maxSteps steps were
  // taken; returns the last step's report.
  public StepInfo Run(uint maxSteps, out bool converged) {
    StepInfo info;
    converged = Step(out info);
    while (!converged && LastStatus != Status.Degenerate && info.StepIndex < maxSteps) converged = Step(out info);
    return info;
  }

  public double Sample(double[] pointMm, bool linear) {
    if (pointMm == null || pointMm.Length != 3) throw new ArgumentException("pointMm must hold 3 values", "pointMm");
    double value;
    Check(Native.ffseg_sample(Live(), pointMm, linear ? 1u : 0u, out value), raw_);
    return value;
  }

  // xyz: 3 floats (mm) per vertex; tris: 3 vertex indices per triangle,
  // counter-clockwise seen from outside.
  public void ExtractMesh(uint obj, out float[] xyz, out uint[] tris) {
    UIntPtr nv, nt;
    Check(Native.ffseg_extract_mesh(Live(), obj, null, UIntPtr.Zero, null, UIntPtr.Zero, out nv, out nt), raw_);
    xyz = new float[3 * (long)nv.ToUInt64()];
    tris = new uint[3 * (long)nt.ToUInt64()];
    Check(Native.ffseg_extract_mesh(raw_, obj, xyz, nv, tris, nt, out nv, out nt), raw_);
  }

  // 1 for every voxel inside the object's mesh, 0 elsewhere; mask is
  // contiguous, i fastest, and must hold every voxel of the volume.
  public void Rasterize(uint obj, byte[] mask) {
    IntPtr e = CheckMask("rasterize", mask);
    Check(Native.ffseg_rasterize(e, obj, mask, IntPtr.Zero), e);
  }

  // 1 for every voxel the object's bounding region owns (thesis 6.2, fig.
  // 6.4; distinct objects' regions never overlap), 0 elsewhere; mask as for
  // Rasterize. Regions exist once Step has run with two or more objects
  // placed; before that, and with MaxObjects = 1, ErrMisuse.
  public void RegionMask(uint obj, byte[] mask) {
    IntPtr e = CheckMask("region_mask", mask);
    Check(Native.ffseg_region_mask(e, obj, mask, IntPtr.Zero), e);
  }

  IntPtr CheckMask(string what, byte[] mask) {
    IntPtr e = Live();
    if (mask == null) throw new ArgumentNullException("mask");
    if (!pinned_.IsAllocated) throw new FfsegException(Status.ErrMisuse, what + ": no volume set");
    if (mask.LongLength < voxels_)
      throw new FfsegException(Status.ErrBufferTooSmall,
                               what + ": mask holds " + mask.LongLength + " voxels, the volume has " + voxels_);
    return e;
  }
}

}  // namespace Ffseg
