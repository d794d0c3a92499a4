package ielas

import org.scalatest.flatspec.AnyFlatSpec

import scala.util.Random

/** The four early stages chained behind the descriptor (support -> filter -> interp and grid, [[EarlyPathChain]])
  * on one small full frame, Middlebury tsukuba 384x288 at config mb-tsukuba, plus two crops, under random input gaps
  * and output back-pressure: every filled lattice node and every grid slot of both views, with their framing,
  * against the golden lattice_L.npy, grid_L.npy and grid_R.npy.
  */
class EarlyPathSpec extends AnyFlatSpec {
  import EarlyPathSpec._

  behavior of "EarlyPathChain (Descriptor -> SupportMatcher -> SupportFilter -> LatticeFill + GridVector)"

  it should "match the golden lattice and grid vectors on the full tsukuba frame at config mb-tsukuba" in {
    runSuite("mb-tsukuba")
  }
}

object EarlyPathSpec {
  import StreamTester._

  case class Case(label: String, left: GrayImage, right: GrayImage)

  def runSuite(config: String): Unit = {
    val p = ElasParams.byName(config)
    val rnd = new Random(seed ^ config.hashCode ^ 0xea)
    val (tl, tr) = TestImages.middleburyTsukuba
    val (kl, kr) = TestImages.kitti2012
    val (cl, cr) = TestImages.middleburyCones
    val all = Seq(
      Case("Middlebury tsukuba 384x288 (full frame)", tl, tr),
      Case("KITTI 2012 000070 crop 300x150 at (700,200)", kl.crop(700, 200, 300, 150), kr.crop(700, 200, 300, 150)),
      Case("Middlebury cones crop 211x97 at (120,150)", cl.crop(120, 150, 211, 97), cr.crop(120, 150, 211, 97)))
    val tmp = tmpDir(s"early-$config")
    val dumps = all.zipWithIndex.map { case (c, i) => GoldenModel.dump(p.name, c.left, c.right, tmp.resolve(f"golden$i%02d")) }
    simulate(new EarlyPathChain(p), tmp.resolve("verilator")) { dut =>
      reset(dut)
      for ((c, dir) <- all.zip(dumps)) {
        val (w, h) = (c.left.width, c.left.height)
        val lattice = NpyArray.read(dir.resolve("lattice_L.npy"))
        val grids = Seq("L", "R").map(v => NpyArray.read(dir.resolve(s"grid_$v.npy")))
        val (lh, lw) = (lattice.shape(0), lattice.shape(1))
        val (gh, gw, slots) = (grids.head.shape(0), grids.head.shape(1), grids.head.shape(2))
        val board = new Scoreboard(s"early path [${c.label}]")
        var nodes = 0L
        var cells = 0L
        poke(dut.io.frameWidth, w); poke(dut.io.frameHeight, h)
        val traffic = Traffic(rnd.nextDouble() * 0.4, rnd.nextDouble() * 0.4)
        val cycles = run[PixelPair, EarlyBeat, PixelBeat, Unit](dut.clock, dut.io.in, pixelBeats(Seq((c.left, c.right))),
          pokePixel,
          dut.io.out, lh.toLong * lw + gh.toLong * gw,
          o => {
            if (peek(o.isGrid)) {
              val k = cells; cells += 1
              val (gy, gx) = ((k / gw).toInt, (k % gw).toInt)
              for ((view, v) <- Seq(o.grid.data.left, o.grid.data.right).zip(Seq("L", "R")); s <- 0 until slots)
                board.check(s"grid_$v (row $gy, col $gx, slot $s)", grids(if (v == "L") 0 else 1)(k * slots + s), peek(view(s)).toLong)
              board.check(s"grid (row $gy, col $gx) sof/eol/eof",
                (if (k == 0) 4 else 0) + (if (gx == gw - 1) 2 else 0) + (if (k == gh.toLong * gw - 1) 1 else 0),
                (if (peek(o.grid.sof)) 4 else 0) + (if (peek(o.grid.eol)) 2 else 0) + (if (peek(o.grid.eof)) 1 else 0))
            } else {
              val k = nodes; nodes += 1
              val (j, i) = ((k / lw).toInt, (k % lw).toInt)
              board.check(s"lattice_L (row $j, col $i)", lattice(k), peek(o.lattice.data).toLong)
              board.check(s"lattice (row $j, col $i) sof/eol/eof",
                (if (k == 0) 4 else 0) + (if (i == lw - 1) 2 else 0) + (if (k == lh.toLong * lw - 1) 1 else 0),
                (if (peek(o.lattice.sof)) 4 else 0) + (if (peek(o.lattice.eol)) 2 else 0) + (if (peek(o.lattice.eof)) 1 else 0))
            }
          },
          (_, _) => (), traffic, rnd, 20L * w * h + 100000, c.label)
        assert(nodes == lh.toLong * lw && cells == gh.toLong * gw, s"${c.label}: $nodes lattice nodes and $cells grid cells")
        assert(board.ok, board.report)
        println(f"  ${p.name}: ${board.report}: $nodes lattice nodes, $cells grid cells, $cycles cycles (input gaps ${traffic.inputGap}%.2f, output stalls ${traffic.outputStall}%.2f)")
      }
    }
  }
}
