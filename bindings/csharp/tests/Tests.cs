// Tests of the C# wrapper against the real library, run under mono:
//   mono Tests.exe LAYOUT_FILE      (LAYOUT_FILE: the output of abi/layout.c)
// Prints one line per test and "N passed, N failed"; exits 1 if any failed.
using System;
using System.Collections.Generic;
using System.IO;
using System.Reflection;
using System.Runtime.InteropServices;
using Ffseg;

static class Tests {
  static void Assert(bool ok, string what) {
    if (!ok) throw new Exception("assertion failed: " + what);
  }

  static FfsegException Throws(Action a) {
    try {
      a();
    } catch (FfsegException ex) {
      return ex;
    }
    throw new Exception("expected an FfsegException");
  }

  // ffseg_volume -> Volume, mean_displacement_mm -> MeanDisplacementMm.
  static string Pascal(string snake) {
    string r = "";
    foreach (string w in snake.Split('_'))
      if (w.Length > 0) r += char.ToUpperInvariant(w[0]) + w.Substring(1);
    return r;
  }

  static readonly Dictionary<string, Type> Structs = new Dictionary<string, Type> {
    {"ffseg_config", typeof(Config)}, {"ffseg_params", typeof(Params)},
    {"ffseg_volume", typeof(Volume)}, {"ffseg_step_info", typeof(StepInfo)},
  };

  static unsafe int UnsafeSize(Type t) {
    if (t == typeof(Config)) return sizeof(Config);
    if (t == typeof(Params)) return sizeof(Params);
    if (t == typeof(Volume)) return sizeof(Volume);
    return sizeof(StepInfo);
  }

  static void LayoutMatchesTheCCompiler(string layoutFile) {
    var seen = new HashSet<string>();
    int lines = 0;
    var wrong = new List<string>();
    foreach (string line in File.ReadAllLines(layoutFile)) {
      string[] w = line.Split(' ');
      ++lines;
      Type t = Structs[w[1]];
      if (w[0] == "struct") {
        int size = int.Parse(w[2]);
        if (Marshal.SizeOf(t) != size || UnsafeSize(t) != size)
          wrong.Add(w[1] + ": C sizeof " + size + ", C# " + Marshal.SizeOf(t) + " / " + UnsafeSize(t));
        continue;
      }
      string name = Pascal(w[2]);
      FieldInfo f = t.GetField(name);
      if (f == null) { wrong.Add(w[1] + "." + w[2] + ": no field " + name + " in " + t.Name); continue; }
      seen.Add(t.Name + "." + name);
      long off = Marshal.OffsetOf(t, name).ToInt64();
      int fsize = Marshal.SizeOf(f.FieldType);  // a fixed buffer's type spans the whole array
      if (off != long.Parse(w[3]) || fsize != int.Parse(w[4]))
        wrong.Add(w[1] + "." + w[2] + ": C offset/size " + w[3] + "/" + w[4] + ", C# " + off + "/" + fsize);
    }
    foreach (Type t in Structs.Values)
      foreach (FieldInfo f in t.GetFields(BindingFlags.Public | BindingFlags.Instance))
        if (!seen.Contains(t.Name + "." + f.Name)) wrong.Add(t.Name + "." + f.Name + ": not in the header");
    Assert(lines >= 44, "layout file has " + lines + " lines");
    Assert(wrong.Count == 0, string.Join("; ", wrong.ToArray()));
  }

  static void StructsAreBlittable() {
    // Pinning refuses any type the marshaller would have to copy.
    foreach (Type t in Structs.Values) {
      GCHandle h = GCHandle.Alloc(Activator.CreateInstance(t), GCHandleType.Pinned);
      h.Free();
    }
  }

  static Config Small(uint n) {
    Config c = Config.Default();
    c.MeshResolution = n;
    return c;
  }

  static void DefaultsAndStatusText() {
    Assert(Library.Version >= 100, "version " + Library.Version);
    Config c = Config.Default();
    Assert(c.StructSize == (uint)Marshal.SizeOf(typeof(Config)), "config struct_size");
    Params p = Params.Default();
    Assert(p.StructSize == (uint)Marshal.SizeOf(typeof(Params)) && p.Reserved1 == 0, "params struct_size, reserved1");
    Assert(p.StepSize > 0 && p.StepSize <= 1, "default step size");
    Assert(Status.Text(Status.ErrInvalidArgument) == "invalid argument", Status.Text(Status.ErrInvalidArgument));
    Assert(Status.Text(-999) == "unknown status", "unknown status");
  }

  static void WorkspaceIsAligned() {
    using (var e = new Engine(Small(10))) {
      Assert(e.WorkspaceAddress.ToInt64() % 64 == 0, "workspace at " + e.WorkspaceAddress);
      using (var big = new Engine(Small(20))) Assert(big.WorkspaceBytes > e.WorkspaceBytes, "sizes grow with n");
    }
  }

  static void ErrorsCarryStatusAndMessage() {
    Config c = Config.Default();
    c.MaxObjects = 0;
    FfsegException ex = Throws(() => new Engine(c));
    Assert(ex.Status == Status.ErrInvalidArgument, "status " + ex.Status);
    Assert(ex.Detail.Contains("max_objects"), ex.Detail);
    using (var e = new Engine(Small(8))) {
      ex = Throws(() => e.InitSphere(0, new double[] {1, 1, 1}, 1));
      Assert(ex.Status == Status.ErrMisuse && ex.Detail.Contains("set_volume"), ex.Message);
      Params p = Params.Default();
      p.Reserved1 = 3;
      Assert(Throws(() => e.SetParams(p)).Status == Status.ErrInvalidArgument, "reserved1 refused");
      // GreyRespacing: 0 automatic (the default since 0.8.0), 1 always, 2
      // never; 3 refused by name.
      Params q = Params.Default();
      Assert(q.GreyRespacing == 0, "grey_respacing default " + q.GreyRespacing);
      q.GreyRespacing = 1;
      e.SetParams(q);
      q.GreyRespacing = 2;
      e.SetParams(q);
      q.GreyRespacing = 3;
      ex = Throws(() => e.SetParams(q));
      Assert(ex.Status == Status.ErrInvalidArgument && ex.Detail.Contains("grey_respacing"), ex.Message);
    }
  }

  static void ShortAffineIsRefusedBeforeTheLibrarySeesIt() {
    using (var e = new Engine(Small(8))) {
      bool threw = false;
      try {
        e.SetVolume(new byte[8 * 8 * 8], new long[] {8, 8, 8}, new double[9]);
      } catch (ArgumentException) {
        threw = true;
      }
      Assert(threw && !e.VolumePinned, "a 9-value affine");
    }
  }

  static void RoundTrip() {
    const uint n = 12;
    var voxels = new short[40 * 36 * 30];
    using (var e = new Engine(Small(n))) {
      e.SetVolume(voxels, new long[] {40, 36, 30}, Engine.Spacing(1, 1, 1.5));
      Assert(e.VolumePinned, "voxels pinned while set");
      double[] c = {20, 18, 22};
      const double r = 8;
      e.InitSphere(0, c, r);
      float[] xyz;
      uint[] tris;
      e.ExtractMesh(0, out xyz, out tris);
      Assert(xyz.Length == 3 * 6 * n * n, "vertex count " + xyz.Length / 3);
      Assert(tris.Length / 3 == 2 * (xyz.Length / 3) - 4, "triangle count " + tris.Length / 3);
      for (int v = 0; v < xyz.Length / 3; ++v) {
        double dx = xyz[3 * v] - c[0], dy = xyz[3 * v + 1] - c[1], dz = xyz[3 * v + 2] - c[2];
        Assert(Math.Abs(Math.Sqrt(dx * dx + dy * dy + dz * dz) - r) < 1e-4, "vertex on the sphere");
      }
      var mask = new byte[voxels.Length];
      e.Rasterize(0, mask);
      int inside = 0;
      foreach (byte b in mask) inside += b;
      double ball = 4.0 / 3.0 * Math.PI * r * r * r;
      Assert(Math.Abs(inside * 1.5 - ball) < 0.1 * ball, inside * 1.5 + " mm^3 inside, ball " + ball);
      Assert(Throws(() => e.Rasterize(0, new byte[mask.Length - 1])).Status == Status.ErrBufferTooSmall, "short mask");
    }
  }

  static byte[] Ellipsoid(long[] d, double[] s, double[] c, double[] a) {
    var v = new byte[d[0] * d[1] * d[2]];
    for (long k = 0; k < d[2]; ++k)
      for (long j = 0; j < d[1]; ++j)
        for (long i = 0; i < d[0]; ++i) {
          double x = (i * s[0] - c[0]) / a[0], y = (j * s[1] - c[1]) / a[1], z = (k * s[2] - c[2]) / a[2];
          v[i + d[0] * (j + d[1] * k)] = (byte)(x * x + y * y + z * z <= 1 ? 1 : 0);
        }
    return v;
  }

  static void SphereGrowsOntoAnEllipsoid() {
    long[] dims = {56, 48, 40};
    double[] s = {1, 1, 1.25}, c = {28, 24, 25}, a = {18, 13, 11};
    byte[] truth = Ellipsoid(dims, s, c, a);
    using (var e = new Engine(Small(16))) {
      e.SetVolume(truth, dims, Engine.Spacing(s[0], s[1], s[2]));
      e.InitSphere(0, c, 4);
      bool converged;
      StepInfo last = e.Run(300, out converged);
      Assert(converged && last.StepIndex > 1, "converged after " + last.StepIndex + " steps");
      var mask = new byte[truth.Length];
      e.Rasterize(0, mask);
      long both = 0, nt = 0, nm = 0;
      for (int i = 0; i < mask.Length; ++i) {
        both += truth[i] & mask[i];
        nt += truth[i];
        nm += mask[i];
      }
      double dice = 2.0 * both / (nt + nm);
      Assert(dice > 0.95, "Dice " + dice);
    }
  }

  static void EmptyBackgroundIsDegenerate() {
    using (var e = new Engine(Small(6))) {
      Params p = Params.Default();
      p.TargetMode = TargetMode.Binary;
      e.SetParams(p);
      e.SetVolume(new byte[24 * 24 * 24], new long[] {24, 24, 24});
      e.InitSphere(0, new double[] {12, 12, 12}, 4);
      bool converged;
      StepInfo last = e.Run(100, out converged);
      Assert(!converged && e.LastStatus == Status.Degenerate && last.StepIndex < 100,
             "degenerate at rest, status " + e.LastStatus + " after " + last.StepIndex + " steps");
      unsafe {
        Assert(last.ObjectFlags[0] == Status.ObjectNoBoundary && last.FlagsAll == Status.ObjectNoBoundary,
               "flags " + last.ObjectFlags[0] + ", all " + last.FlagsAll);
      }
    }
  }

  static long Inside(byte[] m) {
    long n = 0;
    foreach (byte b in m) n += b;
    return n;
  }

  static double Dice(byte[] a, byte[] b) {
    long both = 0;
    for (int i = 0; i < a.Length; ++i) both += a[i] & b[i];
    return 2.0 * both / (Inside(a) + Inside(b));
  }

  static Params Binary(double lambdaPosition, double lambdaLaplacian) {
    Params p = Params.Default();
    p.TargetMode = TargetMode.Binary;
    p.LambdaPosition = lambdaPosition;
    p.LambdaLaplacian = lambdaLaplacian;
    return p;
  }

  // A binary ball grown at n = 12, its mesh resampled into an n = 24 engine
  // (InitMesh) and stepped on to rest: it starts on the coarse surface, and
  // neither Dice nor the voxel count drops (measured in Rust on the same ball:
  // Dice 0.9948 -> 0.9998, 11392 -> 11503 of 11507 voxels).
  static void CoarseToFine() {
    long[] dims = {48, 48, 48};
    double[] one = {1, 1, 1}, c = {24.3, 23.8, 24.2};
    const double r = 14;
    byte[] truth = Ellipsoid(dims, one, c, new double[] {r, r, r});
    var m12 = new byte[truth.Length];
    float[] xyz12;
    uint[] tris;
    using (var coarse = new Engine(Small(12))) {
      coarse.SetParams(Binary(1, 1));
      coarse.SetVolume(truth, dims);
      coarse.InitSphere(0, c, 5);
      bool converged;
      StepInfo last = coarse.Run(300, out converged);
      Assert(converged, "n = 12 converged, status " + coarse.LastStatus + " after " + last.StepIndex + " steps");
      coarse.Rasterize(0, m12);
      coarse.ExtractMesh(0, out xyz12, out tris);
      Assert(xyz12.Length == 3 * 6 * 12 * 12, "n = 12 vertex count " + xyz12.Length / 3);
    }
    using (var fine = new Engine(Small(24))) {
      fine.SetParams(Binary(1, 1));
      fine.SetVolume(truth, dims);
      fine.InitMesh(0, c, 5, xyz12);
      float[] start;
      fine.ExtractMesh(0, out start, out tris);
      Assert(start.Length == 3 * 6 * 24 * 24, "n = 24 vertex count " + start.Length / 3);
      double rMin = double.MaxValue;
      for (int v = 0; v < start.Length / 3; ++v) {
        double dx = start[3 * v] - c[0], dy = start[3 * v + 1] - c[1], dz = start[3 * v + 2] - c[2];
        rMin = Math.Min(rMin, Math.Sqrt(dx * dx + dy * dy + dz * dz));
      }
      Assert(rMin > r - 2, "a resampled vertex " + rMin + " mm from the centre, not on the coarse surface");
      // One vertex short of 6 n^2: refused by the library, the mesh kept.
      var shortXyz = new float[xyz12.Length - 3];
      Array.Copy(xyz12, shortXyz, shortXyz.Length);
      FfsegException ex = Throws(() => fine.InitMesh(0, c, 5, shortXyz));
      Assert(ex.Status == Status.ErrInvalidArgument && ex.Detail.Contains("6 n^2"), ex.Message);
      float[] kept;
      fine.ExtractMesh(0, out kept, out tris);
      for (int i = 0; i < kept.Length; ++i) Assert(kept[i] == start[i], "the refused InitMesh moved vertex " + i / 3);
      bool threw = false;
      try {
        fine.InitMesh(0, c, 5, new float[7]);
      } catch (ArgumentException) {
        threw = true;
      }
      Assert(threw, "7 floats are refused before the library sees them");

      var m24 = new byte[truth.Length];
      bool converged;
      StepInfo last = fine.Run(300, out converged);
      Assert(converged && !fine.Stalled, "n = 24 converged, status " + fine.LastStatus + " after " + last.StepIndex + " steps");
      fine.Rasterize(0, m24);
      double d12 = Dice(m12, truth), d24 = Dice(m24, truth);
      Assert(d24 >= d12 && d24 > 0.99, "Dice n = 12 " + d12 + ", n = 24 " + d24);
      Assert(Inside(m24) >= Inside(m12), "voxels " + Inside(m12) + " -> " + Inside(m24));
    }
  }

  // A ball of radius 20 around a sphere of 5 with the Laplacian weight a
  // million times the positional one: the solve barely moves the mesh, which
  // comes to rest with its targets 15 mm outward. The step must say so
  // (Degenerate, ObjectStalled), not Converged. With the default weights the
  // same start converges unflagged, so the flag is the stall's, not the scene's.
  static void ForcedStallIsReported() {
    long[] dims = {64, 64, 64};
    double[] c = {32, 32, 32};
    byte[] ball = Ellipsoid(dims, new double[] {1, 1, 1}, c, new double[] {20, 20, 20});
    const int nv = 6 * 12 * 12;
    foreach (bool held in new[] {true, false}) {
      using (var e = new Engine(Small(12))) {
        e.SetParams(held ? Binary(1e-6, 1e6) : Binary(1, 1));
        e.SetVolume(ball, dims);
        e.InitSphere(0, c, 5);
        bool converged;
        StepInfo last = e.Run(200, out converged);
        var mask = new byte[ball.Length];
        e.Rasterize(0, mask);
        unsafe {
          string what = (held ? "held" : "free") + ": status " + e.LastStatus + " after " + last.StepIndex +
                        " steps, flags " + last.ObjectFlags[0] + ", far outward " + last.FarOutward[0] +
                        ", inward " + last.FarInward[0] + ", " + Inside(mask) + " of " + Inside(ball) + " voxels";
          if (held) {
            Assert(!converged && e.LastStatus == Status.Degenerate && e.Stalled, what);
            Assert(last.ObjectFlags[0] == Status.ObjectStalled && last.FlagsAll == Status.ObjectStalled, what);
            Assert(last.FarOutward[0] > 0.9 * nv, what);
            Assert(Inside(mask) < Inside(ball) / 10, what);
          } else {
            Assert(converged && !e.Stalled && last.ObjectFlags[0] == 0, what);
            Assert(last.FarOutward[0] + last.FarInward[0] < 0.05 * nv, what);
          }
        }
      }
    }
  }

  static void FailedSetVolumeKeepsThePreviousOnePinned() {
    using (var e = new Engine(Small(8))) {
      var good = new byte[20 * 20 * 20];
      for (int i = 0; i < good.Length; ++i) good[i] = 1;
      e.SetVolume(good, new long[] {20, 20, 20});
      FfsegException ex = Throws(() => e.SetVolume(new byte[10], new long[] {20, 20, 20}));
      Assert(ex.Status == Status.ErrInvalidVolume && ex.Detail.Length > 0, ex.Message);
      Assert(e.VolumePinned, "the engine's volume stays pinned");
      Assert(e.Sample(new double[] {5, 5, 5}, false) == 1, "the previous volume is still read");
      e.InitSphere(0, new double[] {10, 10, 10}, 3);
      e.Rasterize(0, new byte[good.Length]);
    }
  }

  static void DisposeReleasesEverything() {
    var e = new Engine(Small(8));
    e.SetVolume(new float[16 * 16 * 16], new long[] {16, 16, 16});
    e.Dispose();
    Assert(!e.VolumePinned, "unpinned by Dispose");
    bool threw = false;
    try {
      e.InitSphere(0, new double[] {8, 8, 8}, 2);
    } catch (ObjectDisposedException) {
      threw = true;
    }
    Assert(threw, "a call after Dispose");
    e.Dispose();  // twice is fine
  }

  // Two objects in a bar of ones: after a few steps their bounding regions
  // (ffseg_region_mask) are non-empty and share no voxel; before, MISUSE. On
  // voxels, and on cells of 3 voxels when 256 cannot hold a region's box
  // (Config.MaxRegionVoxels, 0.6.0).
  static void TwoObjectsGetDisjointRegions() {
    TwoObjectsGetDisjointRegions(0);
    TwoObjectsGetDisjointRegions(256);
    // The library reads MaxRegionVoxels: regions of 256 voxels take less
    // workspace than the default (MaxRoiVoxels), one out of range is refused by name.
    Config c = Small(6);
    c.MaxObjects = 2;
    long full;
    using (var e = new Engine(c)) full = e.WorkspaceBytes;
    c.MaxRegionVoxels = 256;
    using (var e = new Engine(c))
      Assert(e.WorkspaceBytes < full, "MaxRegionVoxels 256: " + e.WorkspaceBytes + " >= " + full + " bytes");
    c.MaxRegionVoxels = -1;
    FfsegException ex = Throws(() => new Engine(c));
    Assert(ex.Status == Status.ErrInvalidArgument && ex.Detail.Contains("max_region_voxels"), ex.Message);
  }

  static void TwoObjectsGetDisjointRegions(long maxRegion) {
    long[] dims = {40, 12, 12};
    var bar = new byte[40 * 12 * 12];
    for (int k = 3; k < 9; ++k)
      for (int j = 3; j < 9; ++j)
        for (int i = 4; i < 36; ++i) bar[i + 40 * (j + 12 * k)] = 1;
    Config c = Small(6);
    c.MaxObjects = 2;
    c.MaxRegionVoxels = maxRegion;
    using (var e = new Engine(c)) {
      e.SetVolume(bar, dims);
      e.InitSphere(0, new double[] {10, 5.5, 5.5}, 2);
      e.InitSphere(1, new double[] {29, 5.5, 5.5}, 2);
      var r0 = new byte[bar.Length];
      var r1 = new byte[bar.Length];
      Assert(Throws(() => e.RegionMask(0, r0)).Status == Status.ErrMisuse, "no region before a step");
      StepInfo info;
      for (int s = 0; s < 3; ++s) e.Step(out info);
      e.RegionMask(0, r0);
      e.RegionMask(1, r1);
      int n0 = 0, n1 = 0, both = 0;
      for (int v = 0; v < bar.Length; ++v) {
        n0 += r0[v];
        n1 += r1[v];
        both += r0[v] & r1[v];
      }
      Assert(n0 > 100 && n1 > 100, "regions of " + n0 + " and " + n1 + " voxels");
      Assert(both == 0, both + " voxels in both regions");
    }
  }

  static int Main(string[] args) {
    if (args.Length != 1) {
      Console.Error.WriteLine("usage: mono Tests.exe LAYOUT_FILE (the output of abi/layout.c)");
      return 2;
    }
    var tests = new List<KeyValuePair<string, Action>> {
      new KeyValuePair<string, Action>("layout matches the C compiler", () => LayoutMatchesTheCCompiler(args[0])),
      new KeyValuePair<string, Action>("structs are blittable", StructsAreBlittable),
      new KeyValuePair<string, Action>("defaults and status text", DefaultsAndStatusText),
      new KeyValuePair<string, Action>("workspace is 64-byte aligned", WorkspaceIsAligned),
      new KeyValuePair<string, Action>("errors carry status and message", ErrorsCarryStatusAndMessage),
      new KeyValuePair<string, Action>("a 9-value affine is refused", ShortAffineIsRefusedBeforeTheLibrarySeesIt),
      new KeyValuePair<string, Action>("round trip", RoundTrip),
      new KeyValuePair<string, Action>("a sphere grows onto an ellipsoid", SphereGrowsOntoAnEllipsoid),
      new KeyValuePair<string, Action>("a sphere in empty background is degenerate", EmptyBackgroundIsDegenerate),
      new KeyValuePair<string, Action>("coarse to fine: n = 12 then InitMesh at n = 24", CoarseToFine),
      new KeyValuePair<string, Action>("a forced stall is Degenerate with ObjectStalled", ForcedStallIsReported),
      new KeyValuePair<string, Action>("a failed SetVolume keeps the previous volume pinned", FailedSetVolumeKeepsThePreviousOnePinned),
      new KeyValuePair<string, Action>("Dispose releases everything", DisposeReleasesEverything),
      new KeyValuePair<string, Action>("two objects get disjoint bounding regions", TwoObjectsGetDisjointRegions),
    };
    int passed = 0, failed = 0;
    foreach (var t in tests) {
      try {
        t.Value();
        ++passed;
        Console.WriteLine("ok   " + t.Key);
      } catch (Exception ex) {
        ++failed;
        Console.WriteLine("FAIL " + t.Key + ": " + ex.Message);
      }
    }
    Console.WriteLine(passed + " passed, " + failed + " failed");
    return failed == 0 ? 0 : 1;
  }
}
