package ielas

import chisel3.util.log2Ceil

/** The ELAS algorithm parameter set (libelas's two presets; docs/ALGORITHM.md, "Configurations and frames").
  * It fixes the support, prior and post-processing parameters; the hardware shape comes from [[ElasParams]].
  */
sealed abstract class ParameterSet(val name: String) {
  def supportThresholdPercent: Int // best/second-best cost ratio limit, in percent (0.85 -> 85)
  def gamma: Double
  def sradius: Double
  def matchTexture: Int
  def addCorners: Boolean
  def ipolGapWidth: Int
  def filterMedian: Boolean
  def filterAdaptiveMean: Boolean
  def postprocessOnlyLeft: Boolean
}

object ParameterSet {
  case object Robotics extends ParameterSet("robotics") {
    val supportThresholdPercent = 85; val gamma = 3.0; val sradius = 2.0; val matchTexture = 1
    val addCorners = false; val ipolGapWidth = 3; val filterMedian = false; val filterAdaptiveMean = true
    val postprocessOnlyLeft = true
  }
  case object Middlebury extends ParameterSet("middlebury") {
    val supportThresholdPercent = 95; val gamma = 5.0; val sradius = 3.0; val matchTexture = 0
    val addCorners = true; val ipolGapWidth = 5000; val filterMedian = true; val filterAdaptiveMean = false
    val postprocessOnlyLeft = false
  }
  val all: Seq[ParameterSet] = Seq(Robotics, Middlebury)
  def byName(name: String): ParameterSet =
    all.find(_.name == name).getOrElse(
      throw new IllegalArgumentException(s"parameterSet: unknown '$name' (legal: ${all.map(_.name).mkString(", ")})"))
}

/** Lattice-fill rule for nodes of the support lattice that hold no support point. */
sealed abstract class FillRule(val name: String)
object FillRule {
  /** Row-linear interpolation with an up-select for disparity jumps (docs/ALGORITHM.md, "The fill study"); one lattice row look-ahead. */
  case object R7 extends FillRule("r7")
  /** The iELAS paper: horizontal within +-sDelta px, then vertical, then the constant C. */
  case object Paper extends FillRule("paper")
  val all: Seq[FillRule] = Seq(R7, Paper)
  def byName(name: String): FillRule =
    all.find(_.name == name).getOrElse(
      throw new IllegalArgumentException(s"fillRule: unknown '$name' (legal: ${all.map(_.name).mkString(", ")})"))
}

/** The single source of truth for the generator and the golden model.
  *
  * Card parameters: image size maxima, disparity range, window size, stored disparities. Everything else has the
  * libelas default for the chosen parameter set. [[ConfigJson]] writes it (with the derived tables) to
  * `golden/configs/<name>.json`, which the C++ golden model reads, so no value is typed twice.
  */
case class ElasParams(
    name: String = "custom",
    maxWidth: Int = 1242,
    maxHeight: Int = 376,
    dispMax: Int = 255,
    windowSize: Int = 5,
    storedDisparities: Int = 20,
    candidateStep: Int = 5,
    gridSize: Int = 20,
    parameterSet: ParameterSet = ParameterSet.Robotics,
    // support matching and filtering (docs/ALGORITHM.md, "support")
    supportTexture: Int = 10,
    supportMinRange: Int = 10,
    inconWindowSize: Int = 5,
    inconThreshold: Int = 5,
    inconMinSupport: Int = 5,
    lrThreshold: Int = 2,
    // prior (docs/ALGORITHM.md, "dense")
    beta: Double = 0.02,
    sigma: Double = 1.0,
    // post-processing (docs/ALGORITHM.md, "post") and its bounded streaming forms
    speckleSimThreshold: Int = 1,
    speckleSize: Int = 200,
    speckleWindowRows: Int = 16,
    ipolColumnWindow: Int = 32,
    // lattice fill
    fillRule: FillRule = FillRule.R7,
    fillEpsilon: Int = 15,
    sDelta: Int = 50,
    epsilon: Int = 15,
    fillC: Int = 60,
    // implementation knobs
    cyclesPerPixel: Int = 1, // the input takes at most one pixel every cyclesPerPixel clocks; lane counts follow
    supportLanes: Int = 0, //   0 = the lowest count that keeps up with one pixel every cyclesPerPixel clocks
    denseLanes: Int = 0 //      0 = likewise (candidates per view / cyclesPerPixel, rounded up)
) {
  private def rangeCheck(value: Int, lo: Int, hi: Int, what: String): Unit =
    require(value >= lo && value <= hi, s"$what = $value is out of range (legal: $lo..$hi)")

  require(name.nonEmpty && name.forall(c => c.isLetterOrDigit || c == '-' || c == '_'),
    s"name = '$name' must be non-empty and use only letters, digits, '-' and '_'")
  rangeCheck(maxWidth, 32, 8192, "maxWidth")
  rangeCheck(maxHeight, 16, 8192, "maxHeight")
  rangeCheck(dispMax, 15, 1023, "dispMax")
  require(dispMax < maxWidth, s"dispMax = $dispMax must be below maxWidth = $maxWidth (legal: 15..${maxWidth - 1})")
  require(Seq(3, 5, 7).contains(windowSize), s"windowSize = $windowSize is not supported (legal: 3, 5, 7)")
  rangeCheck(storedDisparities, 1, dispMax + 1, "storedDisparities")
  rangeCheck(candidateStep, 2, 16, "candidateStep")
  rangeCheck(gridSize, candidateStep, 256, "gridSize")
  rangeCheck(supportTexture, 0, 2048, "supportTexture")
  rangeCheck(supportMinRange, 1, dispMax, "supportMinRange")
  rangeCheck(inconWindowSize, 1, 16, "inconWindowSize")
  rangeCheck(inconThreshold, 0, dispMax, "inconThreshold")
  rangeCheck(inconMinSupport, 1, (2 * inconWindowSize + 1) * (2 * inconWindowSize + 1), "inconMinSupport")
  rangeCheck(lrThreshold, 0, dispMax, "lrThreshold")
  require(beta > 0.0 && beta <= 1.0, s"beta = $beta is out of range (legal: (0, 1])")
  require(sigma > 0.0 && sigma <= 16.0, s"sigma = $sigma is out of range (legal: (0, 16])")
  rangeCheck(speckleSimThreshold, 0, dispMax, "speckleSimThreshold")
  rangeCheck(speckleSize, 0, 100000, "speckleSize")
  rangeCheck(speckleWindowRows, 1, 64, "speckleWindowRows")
  rangeCheck(ipolColumnWindow, 1, 256, "ipolColumnWindow")
  rangeCheck(fillEpsilon, 0, dispMax, "fillEpsilon")
  rangeCheck(sDelta, 0, maxWidth, "sDelta")
  rangeCheck(epsilon, 0, dispMax, "epsilon")
  rangeCheck(fillC, 0, dispMax, "fillC")
  require(Seq(1, 2, 4, 8).contains(cyclesPerPixel), s"cyclesPerPixel = $cyclesPerPixel is not supported (legal: 1, 2, 4, 8)")
  rangeCheck(supportLanes, 0, dispMax + 1, "supportLanes")
  require(supportLanes == 0 || (Integer.bitCount(supportLanes) == 1 && supportLanes > 2 * (windowSize / 2)),
    s"supportLanes = $supportLanes must be 0 (automatic) or a power of two above windowSize - 1 = ${windowSize - 1}" +
      s" (legal: 0, ${(1 to 10).map(1 << _).filter(l => l > windowSize - 1 && l <= dispMax + 1).mkString(", ")})")
  rangeCheck(denseLanes, 0, dispMax + 1, "denseLanes")

  // ---- derived values ----
  /** Half window: descriptor and support-window reach in pixels (2 for ELAS's 5x5). */
  val windowRadius: Int = windowSize / 2
  /** Descriptor bytes per pixel: the ELAS 16-byte layout at every window size (docs/ALGORITHM.md). */
  val descriptorBytes: Int = 16
  /** Pixels from the border where descriptors are defined (non-zero): windowRadius + 1 (Sobel reach). */
  val descriptorMargin: Int = windowRadius + 1
  /** Pixels from the border where support points can be matched: window corners + descriptor margin. */
  val supportMargin: Int = windowRadius + descriptorMargin
  /** Lattice nodes per row/column: u = 0, step, 2*step, ..., plus a last node at W-1 when it is not on the step. */
  def latticeCount(pixels: Int): Int = (pixels + candidateStep - 1) / candidateStep + (if ((pixels - 1) % candidateStep != 0) 1 else 0)
  val latticeColsMax: Int = latticeCount(maxWidth)
  val latticeRowsMax: Int = latticeCount(maxHeight)
  def gridCount(pixels: Int): Int = (pixels + gridSize - 1) / gridSize
  val gridColsMax: Int = gridCount(maxWidth)
  val gridRowsMax: Int = gridCount(maxHeight)
  val supportThresholdPercent: Int = parameterSet.supportThresholdPercent
  val gamma: Double = parameterSet.gamma
  val sradius: Double = parameterSet.sradius
  val planeRadius: Int = math.max(math.ceil(sigma * sradius).toInt, 2)
  val matchTexture: Int = parameterSet.matchTexture
  val addCorners: Boolean = parameterSet.addCorners
  val ipolGapWidth: Int = parameterSet.ipolGapWidth
  val filterMedian: Boolean = parameterSet.filterMedian
  val filterAdaptiveMean: Boolean = parameterSet.filterAdaptiveMean
  val postprocessOnlyLeft: Boolean = parameterSet.postprocessOnlyLeft

  /** Integer prior P[delta], delta = |d - d_plane| = 0..dispMax (docs/ALGORITHM.md, "dense"): trunc((ln g - ln(g + N)) / beta). */
  val priorTable: Seq[Int] = (0 to dispMax).map(ElasParams.priorEntry(_, gamma, sigma, beta))

  /** Widths. */
  val dispBits: Int = log2Ceil(dispMax + 1)
  /** A disparity as a signed value: 0..dispMax, or -1 for none (lattice, grid and dense streams). */
  val signedDispBits: Int = dispBits + 1
  val colBits: Int = log2Ceil(maxWidth + 1)
  val rowBits: Int = log2Ceil(maxHeight + 1)

  /** Support search cost evaluations per lattice point (left search and right check, 0..dispMax each),
    * and the cycles one lattice point may take at 1 input pixel per clock (step rows x step columns).
    */
  val supportCyclesPerPoint: Int = cyclesPerPixel * candidateStep * candidateStep
  /** Support SAD lanes = column banks: a power of two above 2r (lane k reads bank k of an aligned block of
    * columns). The lowest that schedules a node in supportCyclesPerPoint, else the one that sweeps in one block.
    */
  val supportLanesUsed: Int =
    if (supportLanes > 0) supportLanes
    else {
      val widths = Iterator.iterate(1 << log2Ceil(2 * windowRadius + 1))(_ * 2).takeWhile(_ <= dispMax + 1).toSeq
      widths.find(l => ElasParams.supportNodeCycles(dispMax, windowRadius, l) <= supportCyclesPerPoint)
        .getOrElse(widths.last)
    }
  /** Dense candidates per pixel: the plane range plus the grid candidates. */
  val denseCandidates: Int = 2 * planeRadius + 1 + storedDisparities
  /** Dense SAD lanes per view; each pixel's candidates are evaluated in denseGroups cycles of denseLanesUsed. */
  val denseLanesUsed: Int =
    if (denseLanes > 0) denseLanes else (denseCandidates + cyclesPerPixel - 1) / cyclesPerPixel
  val denseGroups: Int = (denseCandidates + denseLanesUsed - 1) / denseLanesUsed
  require(denseGroups <= cyclesPerPixel, s"denseLanes = $denseLanes is too few for cyclesPerPixel = $cyclesPerPixel" +
    s" (legal: 0 or ${(denseCandidates + cyclesPerPixel - 1) / cyclesPerPixel}..${dispMax + 1})")
}

object ElasParams {
  /** Fixed cycles a support point spends outside its lane sweeps at worst: 4 waiting for the left result (the
    * SupportMatcher search pipeline) and the right reference read (the left one is prefetched meanwhile for the next
    * node; a node that is not prefetched follows one that is not searched and took one cycle).
    */
  val supportOverheadCycles: Int = 5

  /** Cycles of one support sweep over disparities 0..dhi at the worst alignment: the target columns t - r .. t + r
    * of all of them span dhi + 2r + 1 columns, i.e. at most ceil((dhi + 2r) / lanes) + 1 aligned blocks.
    */
  def supportSweepCycles(dhi: Int, windowRadius: Int, lanes: Int): Int = (dhi + 2 * windowRadius + lanes - 1) / lanes + 1

  /** Worst cycles of one support node (both sweeps over 0..dispMax). */
  def supportNodeCycles(dispMax: Int, windowRadius: Int, lanes: Int): Int =
    supportOverheadCycles + 2 * supportSweepCycles(dispMax, windowRadius, lanes)

  def priorEntry(delta: Int, gamma: Double, sigma: Double, beta: Double): Int = {
    val n = math.exp(-(delta.toDouble * delta) / (2.0 * sigma * sigma))
    ((math.log(gamma) - math.log(gamma + n)) / beta).toInt // toInt truncates toward zero, as libelas
  }

  private def preset(name: String, w: Int, h: Int, dmax: Int, set: ParameterSet, windowSize: Int = 5,
      cyclesPerPixel: Int = 1) =
    ElasParams(name = name, maxWidth = w, maxHeight = h, dispMax = dmax, parameterSet = set, windowSize = windowSize,
      fillC = math.min(60, dmax), cyclesPerPixel = cyclesPerPixel)

  /** The named configurations of docs/interfaces.md §1, then small ones for fast tests. */
  val named: Seq[ElasParams] = Seq(
    preset("kitti", 1242, 376, 255, ParameterSet.Robotics),
    preset("kitti-middlebury", 1242, 376, 255, ParameterSet.Middlebury),
    preset("kitti-c8", 1242, 376, 255, ParameterSet.Robotics, cyclesPerPixel = 8), // about the iELAS paper's rate
    preset("tsukuba", 640, 480, 127, ParameterSet.Robotics),
    preset("tsukuba-middlebury", 640, 480, 127, ParameterSet.Middlebury),
    // Small test configurations: narrow frames and short disparity ranges so Verilator builds stay fast.
    preset("small", 128, 64, 31, ParameterSet.Robotics),
    preset("small-middlebury", 128, 64, 31, ParameterSet.Middlebury),
    preset("small-w3", 128, 64, 31, ParameterSet.Robotics, windowSize = 3),
    preset("small-w7", 128, 64, 31, ParameterSet.Robotics, windowSize = 7),
    preset("small-c4", 128, 64, 31, ParameterSet.Robotics, cyclesPerPixel = 4),
    preset("mb-tsukuba", 384, 288, 63, ParameterSet.Robotics)
  )

  def byName(name: String): ElasParams =
    named.find(_.name == name).getOrElse(
      throw new IllegalArgumentException(s"configuration: unknown '$name' (legal: ${named.map(_.name).mkString(", ")}, or a .json file)"))
}
