//! The page of a report: text escaped, each figure's SVG inline once, nothing to run and
//! nothing fetched.
#![allow(clippy::unwrap_used)]

use report::chart::{palette, render_lines, LineChart, Panel, Series};
use report::{Block, Figure, Report, Section};

fn figure(name: &str, title: &str) -> Figure {
    let svg = render_lines(&LineChart {
        title: title.into(),
        x_label: "time (s)".into(),
        panels: vec![Panel {
            y_label: "PV (engineering units)".into(),
            series: vec![Series::line(
                "PV <measured> & \"logged\"",
                (0..50)
                    .map(|i| (i as f64, (i as f64 / 7.0).sin()))
                    .collect(),
                palette::BLACK,
            )],
            ..Panel::default()
        }],
        side_by_side: false,
        size: (480, 300),
    })
    .unwrap();
    Figure {
        name: name.into(),
        caption: format!("Caption of {name}: a < b & c > \"d\""),
        svg,
    }
}

fn report() -> Report {
    let mut sec = Section::new("Numbers <&>");
    sec.push(Block::Paragraph("S < 1 % & J > 0 'quoted' \"too\"".into()))
        .push(Block::Note("<script>alert(1)</script>".into()))
        .push(Block::List(vec!["a & b".into(), "<i>c</i>".into()]))
        .push(Block::Table {
            header: vec!["name".into(), "S <%>".into()],
            rows: vec![vec!["kano × arx".into(), "9.00".into()]],
        })
        .push(Block::Facts(vec![(
            "F_PV <val>".into(),
            "99 & more".into(),
        )]))
        .push(Block::Figure(figure(
            "kano-arx-trends",
            "Time trends: loop a<b & c, kano × arx",
        )))
        .push(Block::Figure(figure(
            "kano-arx-phase",
            "Phase plots: loop a<b & c, kano × arx",
        )));
    Report {
        title: "quantify: loop <a&b>".into(),
        subtitle: "loop.csv · stiction quantify \"quoted\"".into(),
        summary: vec!["The valve <sticks> & slips.".into()],
        sections: vec![sec],
    }
}

#[test]
fn html_escapes_text_and_inlines_each_figure_once() {
    let rep = report();
    let html = rep.to_html(false);
    // Text is escaped.
    assert!(
        html.contains("<title>quantify: loop &lt;a&amp;b&gt;</title>"),
        "{html}"
    );
    assert!(html.contains("<h2>Numbers &lt;&amp;&gt;</h2>"));
    assert!(html.contains("S &lt; 1 % &amp; J &gt; 0 &#39;quoted&#39; &quot;too&quot;"));
    assert!(html.contains("&lt;script&gt;alert(1)&lt;/script&gt;"));
    assert!(html.contains("<li>&lt;i&gt;c&lt;/i&gt;</li>"));
    assert!(html.contains("<th>S &lt;%&gt;</th>"));
    assert!(html.contains("<dt>F_PV &lt;val&gt;</dt><dd>99 &amp; more</dd>"));
    assert!(html.contains("Caption of kano-arx-trends: a &lt; b &amp; c &gt; &quot;d&quot;"));
    assert!(!html.contains("<sticks>") && !html.contains("<a&b>"));
    // Each figure's SVG inline exactly once, in its own <figure>.
    let figs: Vec<&Figure> = rep.figures().collect();
    assert_eq!(figs.len(), 2);
    for f in &figs {
        let start = f.svg.find("<svg").unwrap();
        let inline = f.svg[start..].trim_end();
        assert_eq!(html.matches(inline).count(), 1, "{} inline once", f.name);
        assert!(html.contains(&format!("<figure id=\"{}\">", f.name)));
        assert!(html.contains(&format!("<a href=\"{0}.svg\">{0}.svg</a>", f.name)));
    }
    assert_eq!(html.matches("<svg").count(), figs.len());
    assert_eq!(html.matches("<figure").count(), figs.len());
    assert!(!html.contains(".png"), "no PNG links unless asked");
    // Nothing to run, nothing fetched: no script, and `http` only in the SVG namespace.
    assert!(!html.to_ascii_lowercase().contains("<script"));
    for (i, _) in html.match_indices("http") {
        assert!(
            html[..i].ends_with("xmlns=\""),
            "a URL outside the svg namespace: {}",
            &html[i.saturating_sub(40)..(i + 40).min(html.len())]
        );
    }
    let with_png = rep.to_html(true);
    for f in &figs {
        assert!(with_png.contains(&format!("<a href=\"{0}.png\">{0}.png</a>", f.name)));
    }
}
