//! The block writer and reader of EXR files.

use super::*;

/// What the block writer writes, the exr crate's own whole-image reader reads (any viewer
/// can open the file), and the block reader gives back block by block.
#[test]
fn blocks_round_trip_and_make_a_plain_exr() {
    let (width, height) = (37u32, 21u32);
    let value = |c: usize, x: usize, y: u32| (c as u32 * 100_000) ^ (y * 1000 + x as u32);
    let layout = Layout {
        width,
        height,
        channels: Channels::new(vec![
            ("sums".to_string(), SampleType::U32),
            ("R".to_string(), SampleType::F32),
        ]),
        compression: Compression::ZIP16,
    };
    assert_eq!(layout.channels.index("R"), Some(0));
    let dir = tempfile::tempdir().unwrap();
    let path = dir.path().join("blocks.exr");
    let mut file = std::fs::File::create(&path).unwrap();
    let attribute = AttributeValue::Text(Text::from("hello"));
    let mut seen = Vec::new();
    write(&mut file, &layout, ("note", attribute), |block| {
        seen.push((block.y0, block.lines));
        for line in 0..block.lines {
            for x in 0..width as usize {
                let y = block.y0 + line;
                block.set_f32(line, 0, x, value(0, x, y) as f32);
                block.set_u32(line, 1, x, value(1, x, y));
            }
        }
        Ok(())
    })
    .unwrap();
    drop(file);
    assert_eq!(seen, vec![(0, 16), (16, 5)]);

    let image = read_all_flat_layers_from_file(&path).unwrap();
    let layer = &image.layer_data[0];
    let channel = |name: &str| {
        layer
            .channel_data
            .list
            .iter()
            .find(|c| c.name == *name)
            .unwrap()
    };
    for y in 0..height {
        for x in 0..width as usize {
            let i = y as usize * width as usize + x;
            assert_eq!(
                channel("R").sample_data.value_by_flat_index(i),
                Sample::F32(value(0, x, y) as f32)
            );
            assert_eq!(
                channel("sums").sample_data.value_by_flat_index(i),
                Sample::U32(value(1, x, y))
            );
        }
    }

    let mut reader = open(&path).unwrap();
    assert_eq!((reader.width, reader.height), (width, height));
    assert!(matches!(
        reader.attributes().other.get(&Text::from("note")),
        Some(AttributeValue::Text(t)) if t == &Text::from("hello")
    ));
    let sums = reader.channels.index("sums").unwrap();
    let mut lines = 0;
    while let Some(block) = reader.next_block().unwrap() {
        for line in 0..block.lines {
            let y = block.y0 + line;
            let row = block.row(line, sums);
            for x in 0..width as usize {
                let sample = u32::from_ne_bytes(row[4 * x..4 * x + 4].try_into().unwrap());
                assert_eq!(sample, value(1, x, y));
            }
        }
        lines += block.lines;
    }
    assert_eq!(lines, height);
}

/// A fill that fails stops the write with its own error.
#[test]
fn a_failing_fill_stops_the_write() {
    let layout = Layout {
        width: 4,
        height: 40,
        channels: Channels::new(vec![("R".to_string(), SampleType::F32)]),
        compression: Compression::ZIP16,
    };
    let mut file = tempfile::tempfile().unwrap();
    let attribute = AttributeValue::Text(Text::from("x"));
    let e = write(&mut file, &layout, ("note", attribute), |block| {
        if block.y0 > 0 {
            bail!("no more lines");
        }
        Ok(())
    })
    .unwrap_err();
    assert_eq!(e.to_string(), "no more lines");
}
