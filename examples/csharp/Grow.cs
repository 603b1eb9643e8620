// Grow.cs - a real segmentation from C#: a noisy synthetic scan (a bright
// ellipsoidal organ in darker tissue), the grey-level target of thesis
// chapter 5, a small sphere stepped until it converges, Dice against the organ.
//   mcs -r:Ffseg.dll Grow.cs && mono Grow.exe
using System;
using Ffseg;

static class Grow {
  static int Main() {
    long[] dims = {64, 60, 44};
    double[] s = {1, 1, 1.25}, c = {32, 29, 28}, a = {16, 13, 10};
    var scan = new short[dims[0] * dims[1] * dims[2]];
    var organ = new bool[scan.Length];
    var rng = new Random(17);
    for (long k = 0; k < dims[2]; ++k)
      for (long j = 0; j < dims[1]; ++j)
        for (long i = 0; i < dims[0]; ++i) {
          double x = (i * s[0] - c[0]) / a[0], y = (j * s[1] - c[1]) / a[1], z = (k * s[2] - c[2]) / a[2];
          long idx = i + dims[0] * (j + dims[1] * k);
          organ[idx] = x * x + y * y + z * z <= 1;
          // Gaussian noise, sd 12, by Box-Muller.
          double noise = Math.Sqrt(-2 * Math.Log(1 - rng.NextDouble())) * Math.Cos(2 * Math.PI * rng.NextDouble());
          scan[idx] = (short)Math.Round((organ[idx] ? 170 : 50) + 12 * noise);
        }

    Config cfg = Config.Default();
    cfg.MeshResolution = 16;
    try {
      using (var engine = new Engine(cfg)) {
        Params p = Params.Default();
        p.TargetMode = TargetMode.Intensity;
        engine.SetParams(p);
        engine.SetVolume(scan, dims, Engine.Spacing(s[0], s[1], s[2]));
        engine.InitSphere(0, c, 5);
        bool converged;
        StepInfo last = engine.Run(300, out converged);
        var mask = new byte[scan.Length];
        engine.Rasterize(0, mask);
        long both = 0, truth = 0, found = 0;
        for (long i = 0; i < mask.Length; ++i) {
          if (organ[i]) ++truth;
          found += mask[i];
          if (organ[i] && mask[i] == 1) ++both;
        }
        double dice = 2.0 * both / (truth + found);
        Console.WriteLine("grow (C#, grey levels): {0} after {1} steps, {2} voxels found, {3} in the organ, Dice {4:F3}",
                          converged ? "converged" : "not converged", last.StepIndex, found, truth, dice);
        return converged && dice >= 0.85 ? 0 : 1;
      }
    } catch (FfsegException ex) {
      Console.Error.WriteLine("grow: " + ex.Message);
      return 1;
    }
  }
}
