//! Block names and colours: legacy numeric Minecraft ids (`5:5`, pre-1.13, as in the
//! SIGI example world) to modern block states, modern names to display colours, and
//! identifiers for grammar palettes.
//!
//! Colours are approximate averages of the block textures; a block the table does not
//! know gets a colour derived from its name (stable across runs).

/// Dye colours in Minecraft's data-value order.
const DYES: &[(&str, [u8; 3])] = &[
    ("white", [233, 236, 236]),
    ("orange", [240, 118, 19]),
    ("magenta", [189, 68, 179]),
    ("light_blue", [58, 175, 217]),
    ("yellow", [248, 198, 39]),
    ("lime", [112, 185, 25]),
    ("pink", [237, 141, 172]),
    ("gray", [62, 68, 71]),
    ("light_gray", [142, 142, 134]),
    ("cyan", [21, 137, 145]),
    ("purple", [121, 42, 172]),
    ("blue", [53, 57, 157]),
    ("brown", [114, 71, 40]),
    ("green", [84, 109, 27]),
    ("red", [160, 39, 34]),
    ("black", [20, 21, 25]),
];

/// Wood kinds in data-value order (planks, slabs, saplings).
const WOODS: [&str; 6] = ["oak", "spruce", "birch", "jungle", "acacia", "dark_oak"];

/// Legacy ids whose data value is a dye colour: (id, modern suffix).
const DYED: &[(u16, &str)] = &[
    (35, "wool"),
    (95, "stained_glass"),
    (159, "terracotta"),
    (160, "stained_glass_pane"),
    (171, "carpet"),
    (251, "concrete"),
    (252, "concrete_powder"),
];

/// Legacy stairs ids and their modern names.
const STAIRS: &[(u16, &str)] = &[
    (53, "oak_stairs"),
    (67, "cobblestone_stairs"),
    (108, "brick_stairs"),
    (109, "stone_brick_stairs"),
    (114, "nether_brick_stairs"),
    (128, "sandstone_stairs"),
    (134, "spruce_stairs"),
    (135, "birch_stairs"),
    (136, "jungle_stairs"),
    (156, "quartz_stairs"),
    (163, "acacia_stairs"),
    (164, "dark_oak_stairs"),
    (180, "red_sandstone_stairs"),
    (203, "purpur_stairs"),
];

/// Stone slab materials (legacy 43/44 data & 7).
const STONE_SLABS: [&str; 8] = [
    "smooth_stone_slab",
    "sandstone_slab",
    "petrified_oak_slab",
    "cobblestone_slab",
    "brick_slab",
    "stone_brick_slab",
    "nether_brick_slab",
    "quartz_slab",
];

/// Legacy ids without data variants (or whose variants are orientation only):
/// (id, modern name).
const SIMPLE: &[(u16, &str)] = &[
    (2, "grass_block"),
    (4, "cobblestone"),
    (7, "bedrock"),
    (8, "water"),
    (9, "water"),
    (10, "lava"),
    (11, "lava"),
    (13, "gravel"),
    (14, "gold_ore"),
    (15, "iron_ore"),
    (16, "coal_ore"),
    (19, "sponge"),
    (20, "glass"),
    (21, "lapis_ore"),
    (22, "lapis_block"),
    (23, "dispenser"),
    (25, "note_block"),
    (26, "red_bed"),
    (27, "powered_rail"),
    (28, "detector_rail"),
    (29, "sticky_piston"),
    (30, "cobweb"),
    (31, "grass"),
    (32, "dead_bush"),
    (33, "piston"),
    (37, "dandelion"),
    (38, "poppy"),
    (39, "brown_mushroom"),
    (40, "red_mushroom"),
    (41, "gold_block"),
    (42, "iron_block"),
    (45, "bricks"),
    (46, "tnt"),
    (47, "bookshelf"),
    (48, "mossy_cobblestone"),
    (49, "obsidian"),
    (50, "torch"),
    (51, "fire"),
    (52, "spawner"),
    (54, "chest"),
    (55, "redstone_wire"),
    (56, "diamond_ore"),
    (57, "diamond_block"),
    (58, "crafting_table"),
    (59, "wheat"),
    (60, "farmland"),
    (61, "furnace"),
    (62, "furnace"),
    (63, "oak_sign"),
    (64, "oak_door"),
    (65, "ladder"),
    (66, "rail"),
    (68, "oak_wall_sign"),
    (69, "lever"),
    (70, "stone_pressure_plate"),
    (71, "iron_door"),
    (72, "oak_pressure_plate"),
    (73, "redstone_ore"),
    (76, "redstone_torch"),
    (77, "stone_button"),
    (78, "snow"),
    (79, "ice"),
    (80, "snow_block"),
    (81, "cactus"),
    (82, "clay"),
    (83, "sugar_cane"),
    (84, "jukebox"),
    (85, "oak_fence"),
    (86, "carved_pumpkin"),
    (87, "netherrack"),
    (88, "soul_sand"),
    (89, "glowstone"),
    (91, "jack_o_lantern"),
    (96, "oak_trapdoor"),
    (99, "brown_mushroom_block"),
    (100, "red_mushroom_block"),
    (101, "iron_bars"),
    (102, "glass_pane"),
    (103, "melon"),
    (106, "vine"),
    (107, "oak_fence_gate"),
    (110, "mycelium"),
    (111, "lily_pad"),
    (112, "nether_bricks"),
    (113, "nether_brick_fence"),
    (116, "enchanting_table"),
    (117, "brewing_stand"),
    (118, "cauldron"),
    (120, "end_portal_frame"),
    (121, "end_stone"),
    (122, "dragon_egg"),
    (123, "redstone_lamp"),
    (124, "redstone_lamp"),
    (127, "cocoa"),
    (129, "emerald_ore"),
    (130, "ender_chest"),
    (131, "tripwire_hook"),
    (133, "emerald_block"),
    (138, "beacon"),
    (140, "flower_pot"),
    (143, "oak_button"),
    (144, "skeleton_skull"),
    (145, "anvil"),
    (146, "trapped_chest"),
    (151, "daylight_detector"),
    (152, "redstone_block"),
    (154, "hopper"),
    (158, "dropper"),
    (165, "slime_block"),
    (166, "barrier"),
    (167, "iron_trapdoor"),
    (169, "sea_lantern"),
    (170, "hay_block"),
    (172, "terracotta"),
    (173, "coal_block"),
    (174, "packed_ice"),
    (188, "spruce_fence"),
    (189, "birch_fence"),
    (190, "jungle_fence"),
    (191, "dark_oak_fence"),
    (192, "acacia_fence"),
    (193, "spruce_door"),
    (194, "birch_door"),
    (195, "jungle_door"),
];

/// More legacy ids (continued; split to keep each table readable).
const SIMPLE2: &[(u16, &str)] = &[
    (196, "acacia_door"),
    (197, "dark_oak_door"),
    (183, "spruce_fence_gate"),
    (184, "birch_fence_gate"),
    (185, "jungle_fence_gate"),
    (186, "dark_oak_fence_gate"),
    (187, "acacia_fence_gate"),
    (198, "end_rod"),
    (201, "purpur_block"),
    (202, "purpur_pillar"),
    (206, "end_stone_bricks"),
    (208, "dirt_path"),
    (213, "magma_block"),
    (214, "nether_wart_block"),
    (215, "red_nether_bricks"),
    (216, "bone_block"),
    (218, "observer"),
];

/// Display colours of modern block names (without `minecraft:`), checked first.
const COLORS: &[(&str, [u8; 3])] = &[
    ("stone", [125, 125, 125]),
    ("granite", [149, 103, 85]),
    ("polished_granite", [154, 106, 89]),
    ("diorite", [188, 188, 188]),
    ("polished_diorite", [192, 193, 194]),
    ("andesite", [136, 136, 136]),
    ("polished_andesite", [132, 134, 133]),
    ("grass_block", [110, 150, 70]),
    ("dirt", [134, 96, 67]),
    ("coarse_dirt", [119, 85, 59]),
    ("podzol", [91, 63, 24]),
    ("cobblestone", [127, 127, 127]),
    ("mossy_cobblestone", [110, 118, 94]),
    ("bedrock", [85, 85, 85]),
    ("sand", [219, 207, 163]),
    ("red_sand", [190, 102, 33]),
    ("gravel", [131, 127, 126]),
    ("glass", [200, 225, 235]),
    ("glass_pane", [200, 225, 235]),
    ("sandstone", [216, 203, 155]),
    ("bricks", [150, 97, 83]),
    ("bookshelf", [117, 94, 59]),
    ("obsidian", [15, 10, 24]),
    ("torch", [250, 210, 90]),
    ("glowstone", [171, 131, 84]),
    ("water", [63, 118, 228]),
    ("lava", [207, 92, 20]),
    ("stone_bricks", [122, 121, 122]),
    ("mossy_stone_bricks", [115, 121, 105]),
    ("cracked_stone_bricks", [118, 117, 118]),
    ("chiseled_stone_bricks", [119, 118, 119]),
    ("quartz_block", [235, 229, 222]),
    ("chiseled_quartz_block", [231, 226, 218]),
    ("quartz_pillar", [235, 230, 224]),
    ("smooth_stone", [158, 158, 158]),
    ("nether_bricks", [44, 21, 26]),
    ("netherrack", [97, 38, 38]),
    ("iron_bars", [136, 139, 135]),
    ("ladder", [124, 97, 56]),
    ("terracotta", [152, 94, 67]),
    ("hay_block", [166, 136, 38]),
    ("sea_lantern", [172, 199, 190]),
    ("snow_block", [249, 254, 254]),
    ("ice", [145, 183, 253]),
    ("clay", [160, 166, 179]),
    ("end_stone", [219, 222, 158]),
    ("purpur_block", [169, 125, 169]),
    ("prismarine", [99, 156, 151]),
    ("iron_block", [220, 220, 220]),
    ("gold_block", [246, 208, 61]),
    ("diamond_block", [98, 237, 228]),
    ("emerald_block", [42, 203, 87]),
    ("lapis_block", [30, 67, 140]),
    ("coal_block", [16, 15, 15]),
    ("redstone_block", [175, 24, 5]),
    ("redstone_lamp", [142, 101, 60]),
    ("crafting_table", [119, 73, 42]),
    ("chest", [162, 130, 78]),
];

/// Colours of wood kinds (planks; logs are darker).
const WOOD_COLORS: &[(&str, [u8; 3])] = &[
    ("dark_oak", [66, 43, 20]),
    ("oak", [162, 130, 78]),
    ("spruce", [114, 84, 48]),
    ("birch", [192, 175, 121]),
    ("jungle", [160, 115, 80]),
    ("acacia", [168, 90, 50]),
    ("crimson", [101, 48, 70]),
    ("warped", [43, 104, 99]),
];

/// Blocks the voxel readers treat as empty space.
pub fn is_air(id: &str) -> bool {
    let base = base_name(id);
    matches!(base, "air" | "cave_air" | "void_air" | "structure_void") || id == "0:0" || id == "0"
}

/// The name without namespace and block states: `minecraft:oak_stairs[facing=east]` → `oak_stairs`.
pub fn base_name(id: &str) -> &str {
    let no_state = id.split('[').next().unwrap_or(id);
    match no_state.rsplit_once(':') {
        // `5:0` is a legacy id, not a namespace.
        Some((ns, name)) if !ns.chars().all(|c| c.is_ascii_digit()) => name,
        _ => no_state,
    }
}

/// A legacy `id:data` (or `id`) as numbers.
pub fn parse_legacy(id: &str) -> Option<(u16, u8)> {
    let (a, b) = match id.split_once(':') {
        Some((a, b)) => (a, b),
        None => (id, "0"),
    };
    if a.is_empty() || !a.chars().all(|c| c.is_ascii_digit()) || !b.chars().all(|c| c.is_ascii_digit()) {
        return None;
    }
    Some((a.parse().ok()?, b.parse().ok()?))
}

/// The modern block state (`minecraft:…[…]`) of a legacy id and data value, or none
/// when the table does not know the id. Orientation is kept for stairs, slabs, logs,
/// quartz pillars and doors; other data values that only orient a block are dropped.
pub fn modern_state(id: u16, data: u8) -> Option<String> {
    let mc = |s: &str| Some(format!("minecraft:{s}"));
    if let Some((_, suffix)) = DYED.iter().find(|(i, _)| *i == id) {
        return mc(&format!("{}_{suffix}", DYES[(data & 15) as usize].0));
    }
    if let Some((_, name)) = STAIRS.iter().find(|(i, _)| *i == id) {
        let facing = ["east", "west", "south", "north"][(data & 3) as usize];
        let half = if data & 4 != 0 { "top" } else { "bottom" };
        return mc(&format!("{name}[facing={facing},half={half}]"));
    }
    let wood = WOODS.get((data & 7) as usize).copied().unwrap_or("oak");
    match id {
        1 => {
            let v = [
                "stone",
                "granite",
                "polished_granite",
                "diorite",
                "polished_diorite",
                "andesite",
                "polished_andesite",
            ];
            return mc(v.get(data as usize).copied().unwrap_or("stone"));
        }
        3 => return mc(["dirt", "coarse_dirt", "podzol"].get(data as usize).copied().unwrap_or("dirt")),
        5 => return mc(&format!("{wood}_planks")),
        6 => return mc(&format!("{wood}_sapling")),
        12 => return mc(if data == 1 { "red_sand" } else { "sand" }),
        17 | 162 => {
            let kind = if id == 17 {
                ["oak", "spruce", "birch", "jungle"][(data & 3) as usize]
            } else {
                ["acacia", "dark_oak", "acacia", "dark_oak"][(data & 3) as usize]
            };
            let axis = ["y", "x", "z", "y"][((data >> 2) & 3) as usize];
            return mc(&format!("{kind}_log[axis={axis}]"));
        }
        18 | 161 => {
            let kind = if id == 18 {
                ["oak", "spruce", "birch", "jungle"][(data & 3) as usize]
            } else {
                ["acacia", "dark_oak", "acacia", "dark_oak"][(data & 3) as usize]
            };
            return mc(&format!("{kind}_leaves"));
        }
        24 | 179 => {
            let base = if id == 24 { "sandstone" } else { "red_sandstone" };
            let v = match data {
                1 => format!("chiseled_{base}"),
                2 => format!("cut_{base}"),
                _ => base.to_string(),
            };
            return mc(&v);
        }
        // 43:8, 43:9 and 43:15 are the full smooth blocks (all six faces smooth).
        43 if data == 8 => return mc("smooth_stone"),
        43 if data == 9 => return mc("smooth_sandstone"),
        43 if data == 15 => return mc("smooth_quartz"),
        43 => return mc(&format!("{}[type=double]", STONE_SLABS[(data & 7) as usize])),
        44 => {
            let half = if data & 8 != 0 { "top" } else { "bottom" };
            return mc(&format!("{}[type={half}]", STONE_SLABS[(data & 7) as usize]));
        }
        125 => return mc(&format!("{wood}_slab[type=double]")),
        126 => {
            let half = if data & 8 != 0 { "top" } else { "bottom" };
            return mc(&format!("{wood}_slab[type={half}]"));
        }
        98 => {
            let v = ["stone_bricks", "mossy_stone_bricks", "cracked_stone_bricks", "chiseled_stone_bricks"];
            return mc(v.get(data as usize).copied().unwrap_or("stone_bricks"));
        }
        139 => return mc(if data == 1 { "mossy_cobblestone_wall" } else { "cobblestone_wall" }),
        155 => {
            return mc(match data {
                1 => "chiseled_quartz_block",
                2 => "quartz_pillar[axis=y]",
                3 => "quartz_pillar[axis=x]",
                4 => "quartz_pillar[axis=z]",
                _ => "quartz_block",
            })
        }
        168 => {
            return mc(["prismarine", "prismarine_bricks", "dark_prismarine"]
                .get(data as usize)
                .copied()
                .unwrap_or("prismarine"))
        }
        64 | 71 | 193..=197 => {
            let name = SIMPLE.iter().chain(SIMPLE2.iter()).find(|(i, _)| *i == id).map(|(_, n)| *n)?;
            if data & 8 != 0 {
                let hinge = if data & 1 != 0 { "right" } else { "left" };
                return mc(&format!("{name}[half=upper,hinge={hinge}]"));
            }
            let facing = ["east", "south", "west", "north"][(data & 3) as usize];
            let open = data & 4 != 0;
            return mc(&format!("{name}[facing={facing},half=lower,open={open}]"));
        }
        124 => return mc("redstone_lamp[lit=true]"),
        _ => {}
    }
    SIMPLE.iter().chain(SIMPLE2.iter()).find(|(i, _)| *i == id).and_then(|(_, n)| mc(n))
}

/// Horizontal directions in the order one quarter turn about +y moves them (a turn maps
/// (x, y, z) to (z, y, −x): east → north → west → south → east).
const TURN_ORDER: [&str; 4] = ["east", "north", "west", "south"];

/// `dir` turned `turn` quarter turns, or none for a word that is no horizontal direction.
fn turn_direction(dir: &str, turn: u8) -> Option<&'static str> {
    let i = TURN_ORDER.iter().position(|d| *d == dir)?;
    Some(TURN_ORDER[(i + turn as usize) % 4])
}

/// A rail `shape` turned (`north_south`, `ascending_east`, `south_east`…).
fn turn_rail_shape(v: &str, turn: u8) -> Option<String> {
    if let Some(d) = v.strip_prefix("ascending_") {
        return turn_direction(d, turn).map(|d| format!("ascending_{d}"));
    }
    let (a, b) = v.split_once('_')?;
    let (a, b) = (turn_direction(a, turn)?, turn_direction(b, turn)?);
    // Written north/south first, then east/west (`north_east`, `south_west`, `north_south`).
    let rank = |d: &str| match d {
        "north" => 0,
        "south" => 1,
        "east" => 2,
        _ => 3,
    };
    let (a, b) = if rank(a) <= rank(b) { (a, b) } else { (b, a) };
    Some(format!("{a}_{b}"))
}

/// Legacy data values of blocks whose low bits are a horizontal direction: (ids,
/// directions by value, the mask of the direction bits).
const LEGACY_FACING: &[(&[u16], &[&str], u8)] = &[
    // Stairs: 0 east, 1 west, 2 south, 3 north (bit 4: upside down).
    (&[53, 67, 108, 109, 114, 128, 134, 135, 136, 156, 163, 164, 180, 203], &["east", "west", "south", "north"], 3),
    // Torches: 1 east, 2 west, 3 south, 4 north (5: standing).
    (&[50, 75, 76], &["", "east", "west", "south", "north"], 7),
    // Ladders, chests, furnaces, wall signs, dispensers: 2 north, 3 south, 4 west, 5 east.
    (&[23, 54, 61, 62, 65, 68, 130, 146, 158], &["", "", "north", "south", "west", "east"], 7),
    // Pumpkins, fence gates: 0 south, 1 west, 2 north, 3 east.
    (&[86, 91, 107, 183, 184, 185, 186, 187], &["south", "west", "north", "east"], 3),
];

/// A legacy `id:data` turned `turn` quarter turns about the vertical axis, or none when
/// the data value does not orient the block (or the table does not know it).
fn turn_legacy(id: u16, data: u8, turn: u8) -> Option<String> {
    for (ids, dirs, mask) in LEGACY_FACING {
        if ids.contains(&id) {
            let d = *dirs.get((data & mask) as usize).filter(|d| !d.is_empty())?;
            let t = turn_direction(d, turn)?;
            let v = dirs.iter().position(|x| *x == t)? as u8;
            return Some(format!("{id}:{}", (data & !mask) | v));
        }
    }
    let odd = turn % 2 == 1;
    match id {
        // Logs, hay, purpur pillars, bone blocks: bits 2–3 are the axis (4 x, 8 z).
        17 | 162 | 170 | 202 | 216 => {
            let axis = (data >> 2) & 3;
            let turned = if odd && (axis == 1 || axis == 2) { 3 - axis } else { axis };
            (turned != axis).then(|| format!("{id}:{}", (data & 3) | (turned << 2)))
        }
        // Quartz pillars: 3 x, 4 z.
        155 if odd && (data == 3 || data == 4) => Some(format!("{id}:{}", 7 - data)),
        // Doors, lower half: 0 east, 1 south, 2 west, 3 north (the upper half holds no facing).
        64 | 71 | 193..=197 if data & 8 == 0 => {
            let d = ["east", "south", "west", "north"][(data & 3) as usize];
            let t = turn_direction(d, turn)?;
            let v = ["east", "south", "west", "north"].iter().position(|x| *x == t)? as u8;
            Some(format!("{id}:{}", (data & !3) | v))
        }
        // Standing signs and banners: 16 rotations, 0 south, 4 west, 8 north, 12 east.
        63 | 176 => Some(format!("{id}:{}", (data as u32 + 12 * turn as u32) % 16)),
        _ => None,
    }
}

/// A block id turned `turn` quarter turns about the vertical axis (as Minecraft and
/// WorldEdit turn a template): `facing`, `axis`, `rotation`, a rail's `shape` and the
/// `north`/`east`/`south`/`west` connections of a block state turn; `hinge`, `half` and
/// a stair's `shape` stay (they are relative to the block). Legacy `id:data` values
/// turn by table. None when turning leaves the block as it is.
pub fn turn_block(id: &str, turn: u8) -> Option<String> {
    let turn = turn % 4;
    if turn == 0 {
        return None;
    }
    if let Some((lo, up)) = id.split_once(DOOR_JOIN) {
        // A joined door turns both halves.
        let (a, b) = (turn_block(lo, turn), turn_block(up, turn));
        if a.is_none() && b.is_none() {
            return None;
        }
        return Some(format!("{}{DOOR_JOIN}{}", a.as_deref().unwrap_or(lo), b.as_deref().unwrap_or(up)));
    }
    if let Some((i, d)) = parse_legacy(id) {
        return turn_legacy(i, d, turn).filter(|t| t != id);
    }
    let (name, rest) = id.split_once('[')?;
    let props = rest.strip_suffix(']')?;
    let rail = name.ends_with("rail");
    let mut out: Vec<(String, String)> = Vec::new();
    for p in props.split(',') {
        let (k, v) = p.split_once('=')?;
        let (k, v) = (k.trim(), v.trim());
        let (nk, nv) = match k {
            "facing" => (k.to_string(), turn_direction(v, turn).unwrap_or(v).to_string()),
            "axis" if turn % 2 == 1 => (
                k.to_string(),
                match v {
                    "x" => "z",
                    "z" => "x",
                    o => o,
                }
                .to_string(),
            ),
            "rotation" => match v.parse::<u32>() {
                Ok(r) => (k.to_string(), ((r + 12 * turn as u32) % 16).to_string()),
                Err(_) => (k.to_string(), v.to_string()),
            },
            "shape" if rail => (k.to_string(), turn_rail_shape(v, turn).unwrap_or_else(|| v.to_string())),
            "north" | "east" | "south" | "west" => (turn_direction(k, turn).unwrap_or(k).to_string(), v.to_string()),
            _ => (k.to_string(), v.to_string()),
        };
        out.push((nk, nv));
    }
    // Properties in the order they were written, connections keep their slots' order.
    let turned = format!("{name}[{}]", out.iter().map(|(k, v)| format!("{k}={v}")).collect::<Vec<_>>().join(","));
    let canon = |s: &str| {
        let mut v: Vec<&str> =
            s.split_once('[').map(|(_, r)| r.trim_end_matches(']')).unwrap_or("").split(',').collect();
        v.sort_unstable();
        v.join(",")
    };
    // Same properties in another order is the same block.
    (canon(&turned) != canon(id)).then(|| {
        let mut sorted: Vec<String> = out.iter().map(|(k, v)| format!("{k}={v}")).collect();
        let original: Vec<&str> = props.split(',').map(str::trim).map(|p| p.split('=').next().unwrap_or("")).collect();
        // Keep the original key order: each key's new value in the slot the key had.
        sorted.sort_by_key(|kv| original.iter().position(|k| kv.split('=').next() == Some(*k)).unwrap_or(usize::MAX));
        format!("{name}[{}]", sorted.join(","))
    })
}

/// A block id as a modern block state for `.nbt`/`.schem` output: namespaced ids pass
/// through, legacy `id:data` go through [`modern_state`]; none for anything else.
pub fn to_modern(id: &str) -> Option<String> {
    if let Some((lo, up)) = id.split_once(DOOR_JOIN) {
        return Some(format!("{}{DOOR_JOIN}{}", to_modern(lo)?, to_modern(up)?));
    }
    if let Some((i, d)) = parse_legacy(id) {
        return modern_state(i, d);
    }
    let name = id.split('[').next().unwrap_or(id);
    let ok = |s: &str| {
        !s.is_empty() && s.chars().all(|c| c.is_ascii_lowercase() || c.is_ascii_digit() || "_-./".contains(c))
    };
    match name.split_once(':') {
        Some((ns, n)) if ok(ns) && ok(n) => Some(id.to_string()),
        None if ok(name) && !name.starts_with('#') => Some(format!("minecraft:{id}")),
        _ => None,
    }
}

/// The display colour of a block id: a `#rrggbb` id is its own colour; Minecraft
/// names (legacy or modern) come from the table; anything else gets a stable colour
/// derived from the name.
pub fn color_of(id: &str) -> [u8; 3] {
    if let Some((lo, _)) = id.split_once(DOOR_JOIN) {
        return color_of(lo);
    }
    if let Some(c) = parse_hex_color(id) {
        return c;
    }
    let modern = match parse_legacy(id) {
        Some((i, d)) => modern_state(i, d),
        None => None,
    };
    let name = base_name(modern.as_deref().unwrap_or(id));
    if let Some((_, c)) = COLORS.iter().find(|(n, _)| *n == name) {
        return *c;
    }
    // The longest dye prefix (`light_blue_` before `blue_`).
    let dye = DYES
        .iter()
        .filter(|(d, _)| name.len() > d.len() && name.starts_with(d) && name.as_bytes()[d.len()] == b'_')
        .max_by_key(|(d, _)| d.len());
    if let Some((_, c)) = dye {
        // Stained glass is seen through: lighter than the dye.
        return if name.contains("glass") { c.map(|v| ((v as u16 + 255) / 2) as u8) } else { *c };
    }
    for &(wood, c) in WOOD_COLORS {
        if name.starts_with(wood) {
            return if name.contains("log") { c.map(|v| (v as u16 * 3 / 4) as u8) } else { c };
        }
    }
    for (part, c) in [
        ("glass", [200, 225, 235]),
        ("quartz", [235, 229, 222]),
        ("brick", [150, 97, 83]),
        ("stone", [125, 125, 125]),
        ("cobble", [127, 127, 127]),
        ("sandstone", [216, 203, 155]),
        ("copper", [192, 107, 79]),
        ("deepslate", [80, 80, 82]),
        ("blackstone", [42, 36, 41]),
        ("lantern", [230, 180, 90]),
        ("leaves", [60, 120, 40]),
        ("wool", [233, 236, 236]),
        ("terracotta", [152, 94, 67]),
        ("iron", [200, 200, 200]),
    ] {
        if name.contains(part) {
            return c;
        }
    }
    hash_color(id)
}

/// `#rrggbb` as a colour.
pub fn parse_hex_color(id: &str) -> Option<[u8; 3]> {
    let hex = id.strip_prefix('#')?;
    if hex.len() != 6 || !hex.chars().all(|c| c.is_ascii_hexdigit()) {
        return None;
    }
    let v = u32::from_str_radix(hex, 16).ok()?;
    Some([(v >> 16) as u8, (v >> 8) as u8, v as u8])
}

/// A stable, not too dark, not too saturated colour from a name (FNV-1a hash to a hue).
pub fn hash_color(id: &str) -> [u8; 3] {
    let h = mdg_vm::bundle::fnv1a(id.as_bytes());
    let hue = (h % 360) as f32;
    let (s, v) = (0.45 + (h >> 16) as f32 % 20.0 / 100.0, 0.65 + (h >> 32) as f32 % 25.0 / 100.0);
    let c = v * s;
    let x = c * (1.0 - ((hue / 60.0) % 2.0 - 1.0).abs());
    let (r, g, b) = match (hue / 60.0) as u32 {
        0 => (c, x, 0.0),
        1 => (x, c, 0.0),
        2 => (0.0, c, x),
        3 => (0.0, x, c),
        4 => (x, 0.0, c),
        _ => (c, 0.0, x),
    };
    let m = v - c;
    [r, g, b].map(|u| ((u + m) * 255.0).round().clamp(0.0, 255.0) as u8)
}

/// A readable identifier for a block id (for grammar palettes): `5:5` →
/// `dark_oak_planks`, `minecraft:oak_stairs[facing=east]` → `oak_stairs`, `#ff0000` →
/// `color_ff0000`. Orientation-only legacy data values are kept as a suffix
/// (`53:2` → `oak_stairs_2`) so distinct kinds stay distinguishable.
pub fn identifier(id: &str) -> String {
    if let Some((lo, _)) = id.split_once(DOOR_JOIN) {
        return identifier(lo);
    }
    if let Some(hex) = id.strip_prefix('#') {
        return sanitize(&format!("color_{hex}"));
    }
    if let Some((i, d)) = parse_legacy(id) {
        return match modern_state(i, d) {
            Some(m) => {
                let base = base_name(&m).to_string();
                let keeps_data =
                    DYED.iter().any(|(x, _)| *x == i) || matches!(i, 1 | 3 | 5 | 6 | 12 | 24 | 43 | 98 | 179);
                if d == 0 || keeps_data {
                    sanitize(&base)
                } else {
                    sanitize(&format!("{base}_{d}"))
                }
            }
            None => sanitize(&format!("block_{}", id.replace(':', "_"))),
        };
    }
    sanitize(base_name(id))
}

/// An identifier `[A-Za-z_][A-Za-z0-9_]*` from any text (not `_` alone, which means
/// "no block" in shape rows).
pub fn sanitize(s: &str) -> String {
    let mut out: String = s.chars().map(|c| if c.is_ascii_alphanumeric() || c == '_' { c } else { '_' }).collect();
    if out.is_empty() || out.starts_with(|c: char| c.is_ascii_digit()) {
        out.insert(0, 'b');
    }
    if out.chars().all(|c| c == '_') {
        out.push('b');
    }
    out
}

/// Joins a door's two halves into one kind id: `LOWER+UPPER` (see [`super::doors::merge_doors`]).
pub const DOOR_JOIN: char = '+';

/// Whether `id` is a door half: `Some(true)` for a lower half, `Some(false)` for an
/// upper one (legacy doors 64, 71, 193–197: data bit 8 is the upper half; block states
/// `…_door[…half=lower…]`).
pub fn door_half(id: &str) -> Option<bool> {
    if let Some((i, d)) = parse_legacy(id) {
        return matches!(i, 64 | 71 | 193..=197).then_some(d & 8 == 0);
    }
    let name = base_name(id);
    if !name.ends_with("_door") || name.ends_with("trapdoor") {
        return None;
    }
    let props = id.split_once('[')?.1.trim_end_matches(']');
    props.split(',').find_map(|p| match p.trim() {
        "half=lower" => Some(true),
        "half=upper" => Some(false),
        _ => None,
    })
}

/// The same door (legacy id, or block name) for two halves.
pub(super) fn same_door(lower: &str, upper: &str) -> bool {
    match (parse_legacy(lower), parse_legacy(upper)) {
        (Some((a, _)), Some((b, _))) => a == b,
        (None, None) => lower.split('[').next() == upper.split('[').next(),
        _ => false,
    }
}

/// A block id without its block state or data value: `minecraft:oak_stairs[…]` →
/// `minecraft:oak_stairs`, `53:2` → `53`.
pub fn base_kind(id: &str) -> &str {
    if let Some(i) = id.find('[') {
        return &id[..i];
    }
    if !id.starts_with("minecraft:") && !id.starts_with('#') {
        if let Some(i) = id.find(':') {
            return &id[..i];
        }
    }
    id
}

#[cfg(test)]
mod tests {
    use super::*;

    #[test]
    fn legacy_ids_become_modern_states() {
        assert_eq!(modern_state(5, 5).as_deref(), Some("minecraft:dark_oak_planks"));
        assert_eq!(modern_state(35, 14).as_deref(), Some("minecraft:red_wool"));
        assert_eq!(modern_state(53, 5).as_deref(), Some("minecraft:oak_stairs[facing=west,half=top]"));
        assert_eq!(modern_state(44, 13).as_deref(), Some("minecraft:stone_brick_slab[type=top]"));
        assert_eq!(identifier("5:5"), "dark_oak_planks");
        assert_eq!(identifier("53:2"), "oak_stairs_2");
        assert_eq!(identifier("minecraft:oak_stairs[facing=east]"), "oak_stairs");
        assert_eq!(identifier("#a0b0c0"), "color_a0b0c0");
        assert_eq!(identifier("3000:1"), "block_3000_1");
        assert!(is_air("minecraft:air") && is_air("0:0") && !is_air("1:0"));
    }

    #[test]
    fn colours_are_stable_and_known_blocks_use_the_table() {
        assert_eq!(color_of("1:0"), [125, 125, 125]);
        assert_eq!(color_of("minecraft:stone"), [125, 125, 125]);
        assert_eq!(color_of("#102030"), [16, 32, 48]);
        assert_eq!(color_of("35:14"), DYES[14].1);
        assert_eq!(hash_color("mystery"), hash_color("mystery"));
    }
}
