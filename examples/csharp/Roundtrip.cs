// Roundtrip.cs - the round trip from C#: an engine in its own aligned
// workspace, a volume pinned while set, a sphere placed, mesh and mask read
// back, and the counts the header promises checked.
//   mcs -r:Ffseg.dll Roundtrip.cs && mono Roundtrip.exe
using System;
using Ffseg;

static class Roundtrip {
  static int Main() {
    const uint n = 12;
    Config cfg = Config.Default();
    cfg.MeshResolution = n;
    var voxels = new ushort[40 * 40 * 32];
    using (var engine = new Engine(cfg)) {
      engine.SetVolume(voxels, new long[] {40, 40, 32}, Engine.Spacing(1, 1, 1.25));
      engine.InitSphere(0, new double[] {20, 20, 20}, 8);
      float[] xyz;
      uint[] tris;
      engine.ExtractMesh(0, out xyz, out tris);
      var mask = new byte[voxels.Length];
      engine.Rasterize(0, mask);
      int inside = 0;
      foreach (byte m in mask) inside += m;
      double mm3 = inside * 1.25, ball = 4.0 / 3.0 * Math.PI * 512;
      Console.WriteLine("roundtrip (C#): ffseg {0}, workspace {1} bytes, {2} vertices, {3} triangles, {4:F0} mm^3 inside (ball {5:F0})",
                        Library.Version, engine.WorkspaceBytes, xyz.Length / 3, tris.Length / 3, mm3, ball);
      bool ok = xyz.Length / 3 == 6 * n * n && tris.Length / 3 == 2 * (xyz.Length / 3) - 4 && Math.Abs(mm3 - ball) < 0.1 * ball;
      return ok ? 0 : 1;
    }
  }
}
