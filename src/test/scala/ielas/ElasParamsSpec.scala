package ielas

import java.nio.charset.StandardCharsets
import java.nio.file.{Files, Paths}
import org.scalatest.flatspec.AnyFlatSpec
import org.scalatest.matchers.should.Matchers

class ElasParamsSpec extends AnyFlatSpec with Matchers {
  private val configDir = Paths.get("golden/configs")

  "golden/configs" should "hold exactly the named configurations, as ElasParams writes them today" in {
    val committed = Files.list(configDir).toArray.map(_.toString).filter(_.endsWith(".json")).map(Paths.get(_)).toSeq
    val expectedNames = ElasParams.named.map(p => s"${p.name}.json").sorted
    withClue("stale golden/configs (run `make configs`): ") {
      committed.map(_.getFileName.toString).sorted shouldBe expectedNames
      for (p <- ElasParams.named) {
        val onDisk = new String(Files.readAllBytes(configDir.resolve(s"${p.name}.json")), StandardCharsets.UTF_8)
        withClue(s"${p.name}.json: ") { onDisk shouldBe ConfigJson.toJson(p) }
      }
      val presets = Files.list(configDir.resolve("presets")).toArray.map(_.toString).filter(_.endsWith(".json")).toSeq
      presets.map(Paths.get(_).getFileName.toString).sorted shouldBe ParameterSet.all.map(s => s"${s.name}.json").sorted
      for (set <- ParameterSet.all) {
        val onDisk = new String(Files.readAllBytes(configDir.resolve("presets").resolve(s"${set.name}.json")), StandardCharsets.UTF_8)
        withClue(s"presets/${set.name}.json: ") { onDisk shouldBe ConfigJson.presetJson(set) }
      }
    }
  }

  "ConfigJson" should "read back every named configuration unchanged" in {
    for (p <- ElasParams.named) ConfigJson.fromJson(ConfigJson.toJson(p), s"${p.name}.json") shouldBe p
  }

  it should "reject malformed JSON with the offset" in {
    val e = the[IllegalArgumentException] thrownBy ConfigJson.fromJson("""{"dispMax": 63,, }""", "bad.json")
    e.getMessage should include("bad.json: malformed JSON")
  }

  "the prior table" should "match libelas's values (docs/ALGORITHM.md)" in {
    ElasParams.byName("kitti").priorTable.take(5) shouldBe Seq(-14, -9, -2, 0, 0)
    ElasParams.byName("kitti-middlebury").priorTable.take(5) shouldBe Seq(-9, -5, -1, 0, 0)
    ElasParams.byName("kitti").planeRadius shouldBe 2
    ElasParams.byName("kitti-middlebury").planeRadius shouldBe 3
  }

  "the lattice" should "count nodes at 0, step, ... plus the last pixel when off-step" in {
    val p = ElasParams()
    p.latticeCount(1241) shouldBe 249 // 0..1240, 1240 = W-1 is on the step
    p.latticeCount(1242) shouldBe 250 // 0..1240 plus 1241
    p.latticeCount(376) shouldBe 76 //   0..375, 375 on the step
    p.latticeCount(375) shouldBe 76 //   0..370 plus 374
  }

  "illegal parameters" should "fail at elaboration naming the parameter and its legal range" in {
    def msg(f: => ElasParams): String = (the[IllegalArgumentException] thrownBy f).getMessage
    msg(ElasParams(windowSize = 4)) should (include("windowSize") and include("legal: 3, 5, 7"))
    msg(ElasParams(maxWidth = 16)) should (include("maxWidth") and include("legal: 32..8192"))
    msg(ElasParams(dispMax = 255, storedDisparities = 300)) should (include("storedDisparities") and include("1..256"))
    msg(ElasParams(maxWidth = 64, dispMax = 100)) should (include("dispMax") and include("below maxWidth"))
    msg(ElasParams(gridSize = 3)) should (include("gridSize") and include("legal: 5..256"))
    msg(ConfigJson.load("no-such-config")) should (include("configuration") and include("kitti"))
  }

  "support lanes" should "be the lowest power of two that keeps 1 pixel per clock" in {
    // kitti: a sweep over d = 0..255 touches target columns spanning 255 + 2r + 1 = 260 columns, at worst
    // ceil(259 / L) + 1 aligned blocks; a node is 5 + 2 sweeps within step * step = 25 cycles.
    // L = 16: 5 + 2 * (17 + 1) = 41 > 25; L = 32: 5 + 2 * (9 + 1) = 25 <= 25.
    ElasParams.byName("kitti").supportLanesUsed shouldBe 32
    // tsukuba (dispMax 127): L = 8: 5 + 2 * (17 + 1) = 41; L = 16: 5 + 2 * (9 + 1) = 25.
    ElasParams.byName("tsukuba").supportLanesUsed shouldBe 16
    // small (dispMax 31): L = 8 (the lowest power of two above 2r = 4): 5 + 2 * (5 + 1) = 17.
    ElasParams.byName("small").supportLanesUsed shouldBe 8
    an[IllegalArgumentException] should be thrownBy ElasParams.byName("kitti").copy(supportLanes = 26)
    an[IllegalArgumentException] should be thrownBy ElasParams.byName("kitti").copy(supportLanes = 4)
  }
}
